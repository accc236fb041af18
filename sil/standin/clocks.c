/* Clocks and resets: the frequencies the firmware asks for; resets change nothing here (the
 * peripherals start in their reset state). */
#include "peripherals.h"

#define CLK_48MHZ 48000000u            /* clk_usb and clk_adc run from the 48 MHz USB PLL */

uint32_t clock_get_hz(enum clock_index clk_index) {
    return clk_index == clk_usb || clk_index == clk_adc ? CLK_48MHZ : SIL_CLK_SYS_HZ;
}

void reset_block(uint32_t bits) { (void)bits; }
void unreset_block(uint32_t bits) { (void)bits; }
void unreset_block_wait(uint32_t bits) { (void)bits; }
