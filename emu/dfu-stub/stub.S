@ A stand-in for ST's USB DFU bootloader under QEMU (scripts/qemu-fault-record --dfu): it sits
@ at 0x0800_0000 like the bootloader, and after a reset jumps to the application's reset vector
@ at 0x0800_3004 the way the least helpful bootloader would: VTOR left at its reset value (0,
@ the bootloader's own table through the boot alias) and MSP left at the stub's own stack. An
@ application that does not set VTOR takes its HardFault through this table, which reports it
@ and ends QEMU with a failure; one that does not set MSP runs on the stub's stack, which the
@ fault-record program's stack measurement sees.
        .syntax unified
        .cpu cortex-m3
        .thumb
        .section .text
        .global _start
_start:
vectors:
        .word   0x20010000              @ the stub's stack: the top of an F103's 64 KiB, as ST's
                                        @ bootloader's; flip-link puts the statics there
        .word   reset + 1
        .word   wrong_table + 1         @ NMI
        .word   wrong_table + 1         @ HardFault
        .word   wrong_table + 1         @ MemManage
        .word   wrong_table + 1         @ BusFault
        .word   wrong_table + 1         @ UsageFault
        .thumb_func
reset:
        ldr     r0, =0x08003000
        ldr     r1, [r0, #4]            @ the application's reset vector; MSP and VTOR untouched
        bx      r1
        .thumb_func
wrong_table:
        movs    r0, #0x04               @ SYS_WRITE0
        ldr     r1, =message
        bkpt    0xab
        movs    r0, #0x18               @ SYS_EXIT
        ldr     r1, =0x20023            @ ADP_Stopped_RunTimeErrorUnknown: QEMU exits with 1
        bkpt    0xab
        b       .
        .ltorg
message:
        .asciz  "dfu-stub: an exception went through the bootloader's vector table (VTOR not set by the application)\n"
