// Per-axis loops (a constant 3 steps) on hot paths. GCC -O2 keeps them as loops (its size
// heuristics), and callgrind measured the loop overhead at up to a fifth of a k-d tree query's or
// a map build's instructions. Unrolled, every operation and its order stay the same (the axes are
// independent): the same bits on every ISA.
#pragma once

#define V2XLOC_UNROLL_AXES _Pragma("GCC unroll 3")
