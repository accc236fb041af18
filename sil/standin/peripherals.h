/* The modelled RP2040 peripherals, one file each, as the frame transport and power-on see them:
 * what the world sets on them, and the two that the machine runs (peripheral_interface.h). The
 * firmware sees them through the pico-sdk's own functions (include/sil_sdk.h). */
#ifndef SIL_PERIPHERALS_H
#define SIL_PERIPHERALS_H

#include "peripheral_interface.h"

/* Write a register the firmware only reads (the SDK declares it const volatile). */
#define SIL_SET_REG(reg) (*(volatile uint32_t *)&(reg))

/* The system clock the firmware's PIO dividers and clock_get_hz() assume. */
#define SIL_CLK_SYS_HZ 125000000u

/* uart.c: the command port (uart0) */
extern const struct sil_peripheral sil_uart_peripheral;
void sil_uart_host_bytes(uint64_t t, const uint8_t *bytes, uint16_t count);   /* from the host */
uint8_t sil_uart_host_status(void);    /* the command port at rest: see uart.c */
void sil_uart_flush_output(void);      /* bytes to the host not yet given to the world */

/* pio.c: the PIO state machines, the ports' UARTs */
extern const struct sil_peripheral sil_pio_peripheral;
void sil_pio_port_bytes(int port, uint64_t t, uint32_t baud, const uint8_t *bytes, uint16_t count);
void sil_pio_port_cut(int port, uint64_t t);   /* the device stopped: drop its unsent bytes */

/* gpio.c: pins, the ports' ID lines, the fault pins */
void sil_gpio_init(void);
void sil_gpio_set_id(int port, uint16_t signature, uint8_t rx_idle_level);
void sil_gpio_set_fault_pins(uint8_t port_ok, uint8_t motor_ok);
uint8_t sil_gpio_id_pins(int port);    /* the port's ID pins as its motor driver reads them */

/* i2c.c: the ports' motor drivers and the accelerometer */
void sil_i2c_set_fault_regs(int port, const uint8_t *regs3);
void sil_i2c_set_drive_stops(uint8_t mask);   /* ports whose drive changes stop the firmware */

/* adc.c: the input voltage */
void sil_adc_init(void);
extern const struct sil_peripheral sil_adc_peripheral;    /* conversions seen at timer reads */
void sil_adc_set_vin(uint16_t raw);

#endif
