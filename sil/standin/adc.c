/* The ADC: the input voltage (Vin) as the world sets it, one input.
 *
 * A conversion starts when the firmware sets START_ONCE in CS, and its result stays in RESULT
 * until the next one: the firmware reads at each millisecond tick the conversion it started at
 * the tick before, so a change of Vin shows at the second tick after it
 * (docs/FIRMWARE-BEHAVIOUR.md#fb-vin). CS is plain memory here, so the start is seen at the CPU's
 * next timer read, a main-loop pass later (a few microseconds; the chip's conversion takes 2). */
#include "peripherals.h"

#define VIN_DEFAULT_RAW 0x3ff          /* until the world says: a reading, not zero volts */
#define ADC_CS_START_ONCE (1u << 2)    /* RP2040 datasheet, ADC CS register: self-clearing */

adc_hw_t sil_adc_hw;
static uint16_t vin_raw = VIN_DEFAULT_RAW;    /* the pin's level now */

void adc_init(void) {}
void adc_gpio_init(uint gpio) { (void)gpio; }
void adc_select_input(uint input) { (void)input; }
uint16_t adc_read(void) { return vin_raw; }  /* a blocking conversion: the level now */

static void adc_timer_read(void) {
    if (!(sil_adc_hw.cs & ADC_CS_START_ONCE)) return;
    SIL_SET_REG(sil_adc_hw.cs) = sil_adc_hw.cs & ~ADC_CS_START_ONCE;
    SIL_SET_REG(sil_adc_hw.result) = vin_raw;
}

const struct sil_peripheral sil_adc_peripheral = {.timer_read = adc_timer_read};

void sil_adc_set_vin(uint16_t raw) { vin_raw = raw; }
void sil_adc_init(void) {
    vin_raw = VIN_DEFAULT_RAW;
    SIL_SET_REG(sil_adc_hw.result) = VIN_DEFAULT_RAW;
}
