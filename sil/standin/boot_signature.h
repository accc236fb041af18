/* The image signature the bootloader leaves at the top of RAM (boot_signature.c). */
#ifndef SIL_BOOT_SIGNATURE_H
#define SIL_BOOT_SIGNATURE_H

#include <stddef.h>
#include <stdint.h>

void sil_boot_signature_map(void);                          /* at power-on */
void sil_boot_signature_store(const uint8_t *bytes, size_t count);   /* the world's copy of it */

#endif
