/* The ADC: the input voltage (Vin) as the world sets it; one input, read at once. */
#include "peripherals.h"

#define VIN_DEFAULT_RAW 0x3ff          /* until the world says: a reading, not zero volts */

adc_hw_t sil_adc_hw;

void adc_init(void) {}
void adc_gpio_init(uint gpio) { (void)gpio; }
void adc_select_input(uint input) { (void)input; }
uint16_t adc_read(void) { return (uint16_t)sil_adc_hw.result; }

void sil_adc_set_vin(uint16_t raw) { SIL_SET_REG(sil_adc_hw.result) = raw; }
void sil_adc_init(void) { SIL_SET_REG(sil_adc_hw.result) = VIN_DEFAULT_RAW; }
