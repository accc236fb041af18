/* The project's stand-in for the parts of the pico-sdk a Build HAT firmware tree uses.
 *
 * Written from the SDK's public API (names, types, register layouts of the RP2040 datasheet),
 * so that a firmware tree compiles unchanged for the host. Every SDK header the firmware
 * includes (pico/stdlib.h, hardware/uart.h, ...) is a one-line include of this file.
 * The behaviour behind these declarations lives in machine.c (time, interrupts) and one file
 * per peripheral: uart.c, pio.c, gpio.c, i2c.c, adc.c, clocks.c; see sil/README.md.
 */
#ifndef SIL_SDK_H
#define SIL_SDK_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

typedef unsigned int uint;
typedef volatile uint32_t io_rw_32;
typedef const volatile uint32_t io_ro_32;
typedef volatile uint32_t io_wo_32;
typedef volatile uint16_t io_rw_16;
typedef volatile uint8_t io_rw_8;
typedef const volatile uint8_t io_ro_8;

#define PICO_OK 0
#define PICO_ERROR_TIMEOUT (-1)
#define PICO_ERROR_GENERIC (-2)

/* ---- time ------------------------------------------------------------------------------ */
typedef uint64_t absolute_time_t;
uint64_t time_us_64(void);
uint32_t time_us_32(void);
absolute_time_t get_absolute_time(void);
void sleep_us(uint64_t us);
void sleep_ms(uint32_t ms);
void busy_wait_us(uint64_t us);
void busy_wait_us_32(uint32_t us);
void busy_wait_ms(uint32_t ms);
bool stdio_init_all(void);
void tight_loop_contents(void);

/* ---- interrupts (NVIC numbers of the RP2040) ------------------------------------------- */
typedef void (*irq_handler_t)(void);
enum {
    TIMER_IRQ_0 = 0, PIO0_IRQ_0 = 7, PIO0_IRQ_1 = 8, PIO1_IRQ_0 = 9, PIO1_IRQ_1 = 10,
    UART0_IRQ = 20, UART1_IRQ = 21, SIL_NUM_IRQS = 32
};
void irq_set_exclusive_handler(uint num, irq_handler_t handler);
void irq_set_enabled(uint num, bool enabled);
void irq_set_pending(uint num);
uint32_t save_and_disable_interrupts(void);
void restore_interrupts(uint32_t status);

/* ---- GPIO ------------------------------------------------------------------------------- */
enum gpio_function {
    GPIO_FUNC_XIP = 0, GPIO_FUNC_SPI = 1, GPIO_FUNC_UART = 2, GPIO_FUNC_I2C = 3, GPIO_FUNC_PWM = 4,
    GPIO_FUNC_SIO = 5, GPIO_FUNC_PIO0 = 6, GPIO_FUNC_PIO1 = 7, GPIO_FUNC_GPCK = 8, GPIO_FUNC_USB = 9,
    GPIO_FUNC_NULL = 0x1f
};
#define GPIO_OUT 1
#define GPIO_IN 0
void gpio_init(uint gpio);
void gpio_set_dir(uint gpio, bool out);
void gpio_put(uint gpio, bool value);
bool gpio_get(uint gpio);
void gpio_pull_up(uint gpio);
void gpio_pull_down(uint gpio);
void gpio_disable_pulls(uint gpio);
void gpio_set_function(uint gpio, enum gpio_function fn);

/* ---- UART (PL011 register block) -------------------------------------------------------- */
typedef struct {
    io_rw_32 dr, rsr;
    uint32_t _pad0[4];
    io_ro_32 fr;
    uint32_t _pad1;
    io_rw_32 ilpr, ibrd, fbrd, lcr_h, cr, ifls, imsc;
    io_ro_32 ris, mis;
    io_wo_32 icr;
    io_rw_32 dmacr;
} uart_hw_t;
typedef struct uart_inst uart_inst_t;
extern uart_hw_t sil_uart_hw[2];
#define uart0 ((uart_inst_t *)&sil_uart_hw[0])
#define uart1 ((uart_inst_t *)&sil_uart_hw[1])
static inline uart_hw_t *uart_get_hw(uart_inst_t *uart) { return (uart_hw_t *)uart; }
uint uart_init(uart_inst_t *uart, uint baudrate);
void uart_set_fifo_enabled(uart_inst_t *uart, bool enabled);

/* ---- PIO -------------------------------------------------------------------------------- */
typedef struct {
    io_rw_32 clkdiv, execctrl, shiftctrl;
    io_ro_32 addr;
    io_rw_32 instr, pinctrl;
} pio_sm_hw_t;
typedef struct {
    io_rw_32 ctrl;
    io_ro_32 fstat;
    io_rw_32 fdebug;
    io_ro_32 flevel;
    io_wo_32 txf[4];
    io_ro_32 rxf[4];
    io_rw_32 irq;
    io_wo_32 irq_force;
    io_rw_32 input_sync_bypass, dbg_padout, dbg_padoe, dbg_cfginfo;
    io_wo_32 instr_mem[32];
    pio_sm_hw_t sm[4];
    io_ro_32 intr;
    io_rw_32 inte0, intf0;
    io_ro_32 ints0;
    io_rw_32 inte1, intf1;
    io_ro_32 ints1;
} pio_hw_t;
typedef pio_hw_t *PIO;
extern pio_hw_t sil_pio_hw[2];
#define pio0 (&sil_pio_hw[0])
#define pio1 (&sil_pio_hw[1])

/* What a state machine runs is known from its program's text (see sil/pio_header.py):
 * the stand-in models the program's job (an 8N1 UART transmitter or receiver), not its code. */
enum sil_pio_kind { SIL_PIO_OTHER = 0, SIL_PIO_UART_TX = 1, SIL_PIO_UART_RX = 2 };
typedef struct pio_program {
    const uint16_t *instructions;
    uint8_t length;
    int8_t origin;
    uint8_t sil_kind;
} pio_program_t;
typedef struct {
    uint32_t clkdiv, execctrl, shiftctrl, pinctrl;
    int out_pin, in_pin, kind;
} pio_sm_config;

pio_sm_config sil_pio_default_config(uint offset);
void sm_config_set_out_shift(pio_sm_config *config, bool shift_right, bool autopull, uint threshold);
void sm_config_set_in_shift(pio_sm_config *config, bool shift_right, bool autopush, uint threshold);
void sm_config_set_out_pins(pio_sm_config *config, uint out_base, uint out_count);
void sm_config_set_sideset_pins(pio_sm_config *config, uint sideset_base);
void sm_config_set_in_pins(pio_sm_config *config, uint in_base);
void sm_config_set_jmp_pin(pio_sm_config *config, uint pin);
void sm_config_set_clkdiv(pio_sm_config *config, float div);
int pio_add_program(PIO pio, const pio_program_t *program);
void pio_clear_instruction_memory(PIO pio);
int pio_sm_init(PIO pio, uint sm, uint initial_pc, const pio_sm_config *config);
void pio_sm_set_enabled(PIO pio, uint sm, bool enabled);
void pio_sm_set_pins_with_mask(PIO pio, uint sm, uint32_t pin_values, uint32_t pin_mask);
void pio_sm_set_pindirs_with_mask(PIO pio, uint sm, uint32_t pin_dirs, uint32_t pin_mask);
int pio_sm_set_consecutive_pindirs(PIO pio, uint sm, uint pin_base, uint pin_count, bool is_out);
void pio_gpio_init(PIO pio, uint pin);
bool pio_sm_is_tx_fifo_full(PIO pio, uint sm);
bool pio_sm_is_tx_fifo_empty(PIO pio, uint sm);
bool pio_sm_is_rx_fifo_empty(PIO pio, uint sm);
bool pio_sm_is_rx_fifo_full(PIO pio, uint sm);
void pio_sm_put(PIO pio, uint sm, uint32_t data);
void pio_sm_put_blocking(PIO pio, uint sm, uint32_t data);
uint32_t pio_sm_get(PIO pio, uint sm);
uint32_t pio_sm_get_blocking(PIO pio, uint sm);

/* ---- I2C -------------------------------------------------------------------------------- */
typedef struct i2c_inst { int bus; } i2c_inst_t;
extern i2c_inst_t sil_i2c[2];
#define i2c0 (&sil_i2c[0])
#define i2c1 (&sil_i2c[1])
uint i2c_init(i2c_inst_t *i2c, uint baudrate);
void i2c_deinit(i2c_inst_t *i2c);
int i2c_write_timeout_us(i2c_inst_t *i2c, uint8_t addr, const uint8_t *src, size_t len, bool nostop,
                         uint timeout_us);
int i2c_read_timeout_us(i2c_inst_t *i2c, uint8_t addr, uint8_t *dst, size_t len, bool nostop,
                        uint timeout_us);
int i2c_write_blocking(i2c_inst_t *i2c, uint8_t addr, const uint8_t *src, size_t len, bool nostop);
int i2c_read_blocking(i2c_inst_t *i2c, uint8_t addr, uint8_t *dst, size_t len, bool nostop);

/* ---- ADC -------------------------------------------------------------------------------- */
typedef struct {
    io_rw_32 cs;
    io_ro_32 result;
    io_rw_32 fcs;
    io_ro_32 fifo;
    io_rw_32 div;
    io_ro_32 intr;
    io_rw_32 inte, intf;
    io_ro_32 ints;
} adc_hw_t;
extern adc_hw_t sil_adc_hw;
#define adc_hw (&sil_adc_hw)
void adc_init(void);
void adc_gpio_init(uint gpio);
void adc_select_input(uint input);
uint16_t adc_read(void);

/* ---- clocks and resets ------------------------------------------------------------------ */
enum clock_index {
    clk_gpout0 = 0, clk_gpout1, clk_gpout2, clk_gpout3, clk_ref, clk_sys, clk_peri, clk_usb, clk_adc,
    clk_rtc, CLK_COUNT
};
uint32_t clock_get_hz(enum clock_index clk_index);
#define RESETS_RESET_PIO0_BITS 0x00000400u
#define RESETS_RESET_PIO1_BITS 0x00000800u
void reset_block(uint32_t bits);
void unreset_block(uint32_t bits);
void unreset_block_wait(uint32_t bits);

#endif
