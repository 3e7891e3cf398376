@ Entry of the semihosting target image, before newlib's rdimon crt0 (_mainCRTStartup): our
@ exception vectors, then the FPU (rdimon's crt0 enables neither). Every exception a correct run
@ never takes ends the run at once with a failing status (semihosting SYS_EXIT with
@ ADP_Stopped_RunTimeErrorUnknown: QEMU exits 1) after naming it, instead of hanging.
        .syntax unified
        .arm

        .section .text.v2xloc_reset, "ax", %progbits
        .global v2xloc_reset
        .type   v2xloc_reset, %function
v2xloc_reset:
        ldr     r0, =v2xloc_vectors
        mcr     p15, 0, r0, c12, c0, 0      @ VBAR
        mrc     p15, 0, r0, c1, c0, 2       @ CPACR: cp10, cp11 full access
        orr     r0, r0, #(0xf << 20)
        mcr     p15, 0, r0, c1, c0, 2
        isb
        mov     r0, #0x40000000             @ FPEXC.EN
        vmsr    fpexc, r0
        b       _mainCRTStartup
        .size   v2xloc_reset, . - v2xloc_reset

        .section .text.v2xloc_vectors, "ax", %progbits
        .balign 32
v2xloc_vectors:
        b       fault_reset
        b       fault_undefined
        b       fault_svc
        b       fault_prefetch
        b       fault_data
        b       fault_reserved
        b       fault_irq
        b       fault_fiq

        .macro  fault name, text
\name:
        adr     r1, 1f
        mov     r0, #0x04                   @ SYS_WRITE0
        svc     0x123456
        mov     r0, #0x18                   @ SYS_EXIT
        ldr     r1, =0x20023                @ ADP_Stopped_RunTimeErrorUnknown
        svc     0x123456
        b       .
1:      .asciz  "\text\n"
        .balign 4
        .endm

        fault   fault_reset, "v2xloc target: FAULT reset vector"
        fault   fault_undefined, "v2xloc target: FAULT undefined instruction"
        fault   fault_svc, "v2xloc target: FAULT unexpected SVC"
        fault   fault_prefetch, "v2xloc target: FAULT prefetch abort"
        fault   fault_data, "v2xloc target: FAULT data abort"
        fault   fault_reserved, "v2xloc target: FAULT reserved vector"
        fault   fault_irq, "v2xloc target: FAULT unexpected IRQ"
        fault   fault_fiq, "v2xloc target: FAULT unexpected FIQ"
        .ltorg
