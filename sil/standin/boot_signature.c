/* The bootloader leaves the loaded image's signature at the top of the RP2040's RAM; the
 * firmware's `signature` command reads it there, at its absolute address, so that address
 * must exist in this process too: the page holding it is mapped at power-on, and the world
 * writes the signature into it. */
#include "boot_signature.h"

#include <stdio.h>
#include <string.h>
#include <sys/mman.h>

/* Where the bootloader puts the signature: the last 256 bytes of the RP2040's striped SRAM
 * (0x20000000..0x2003FFFF). */
#define SIGNATURE_ADDR 0x2003ff00u
#define SIGNATURE_ROOM 256u
/* The host page that holds it (4 KiB pages). */
#define SIGNATURE_PAGE 0x2003f000u
#define PAGE_SIZE 0x1000u

void sil_boot_signature_map(void) {
    void *pad = mmap((void *)(uintptr_t)SIGNATURE_PAGE, PAGE_SIZE, PROT_READ | PROT_WRITE,
                     MAP_PRIVATE | MAP_ANONYMOUS | MAP_FIXED_NOREPLACE, -1, 0);
    if (pad == MAP_FAILED || pad != (void *)(uintptr_t)SIGNATURE_PAGE)
        fprintf(stderr, "sil: could not map the bootloader pad at 0x%X\n", SIGNATURE_PAGE);
}

void sil_boot_signature_store(const uint8_t *bytes, size_t count) {
    memcpy((void *)(uintptr_t)SIGNATURE_ADDR, bytes, count < SIGNATURE_ROOM ? count : SIGNATURE_ROOM);
}
