#!/usr/bin/env bash
# Fails if the bare-metal image links heap or exception machinery or misses an algo stage;
# prints its static RAM.
set -euo pipefail
elf=${1:?usage: check-baremetal.sh IMAGE.elf}
forbidden='^(malloc|free|calloc|realloc|_malloc_r|_free_r|_Znwj|_Znaj|_Znwm|_Znam|_ZdlPv|_ZdaPv|_ZdlPvj|__cxa_allocate_exception|__cxa_throw|__cxa_begin_catch|__gxx_personality_v0|_Unwind_Resume|__cxa_pure_virtual_heap)$'
found=$(arm-none-eabi-nm --defined-only -g "$elf" | awk '{print $3}' | grep -E "$forbidden" || true)
undef=$(arm-none-eabi-nm -u "$elf" | awk '{print $2}' | grep -E "$forbidden" || true)
if [ -n "$found$undef" ]; then
  echo "check-baremetal: FORBIDDEN symbols in $elf:"; echo "$found $undef"; exit 1
fi
# Every stage must be linked in (a stage the image does not call is a stage the check does not prove).
stages='v2xloc::register_clouds( v2xloc::kabsch_fit( v2xloc::MapFusion::insert( v2xloc::check_background( v2xloc::deskew(
v2xloc::LidarOdometry::register_frame( v2xloc::FixedLagValidityGate::push(
v2xloc::CausalValidityGate::push( v2xloc::Ekf::on_registration( v2xloc::registration_covariance(
v2xloc::geodetic_to_enu( v2xloc::enu_to_geodetic( v2xloc::stereo_to_cloud('
defined=$(arm-none-eabi-nm -C --defined-only "$elf")
missing=""
for s in $stages; do
  grep -qF " $s" <<<"$defined" || missing="$missing $s"
done
if [ -n "$missing" ]; then
  echo "check-baremetal: stages not linked into $elf:$missing"; exit 1
fi
arm-none-eabi-size -A "$elf" | awk '
  $1==".data"{d=$2} $1==".bss"{b=$2} $1==".text"{t=$2}
  END{printf "check-baremetal: no malloc/free/new/delete/exception symbols; .text %d B, static RAM .data+.bss = %d B (%.1f KiB)\n", t, d+b, (d+b)/1024}'
