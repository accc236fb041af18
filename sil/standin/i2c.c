/* I2C: the four ports' motor drivers (a register file each; the drive, the fault registers and
 * the ID pins behind it) and the accelerometer, which acknowledges and reads zeros. Transfers
 * take 400 kHz bus time. A change of a port's drive goes to the world as an event. */
#include <string.h>

#include "board.h"
#include "machine.h"
#include "peripherals.h"

#define I2C_NS_PER_BYTE 22500u         /* 9 bits at 400 kHz */
#define ACCEL_BUS 0                    /* the accelerometer: on I2C0 at 0x6a */
#define ACCEL_ADDR 0x6a

/* The motor driver's registers the firmware uses */
#define REG_ID_PINS 0x4B               /* read: the port's ID pins (gpio.c) */
#define REG_FLAGS 0x4C                 /* outputs on (bits 0-4), direction (bit 5); faults (bits 0-3) */
#define REG_FAULTS 0x4D                /* 0x4D..0x4F: the fault registers the world sets */
#define REG_FAULTS_LAST 0x4F
#define REG_DUTY 0xA1
#define REG_RESET 0xF5                 /* bit 0: soft reset */
#define FLAGS_OUTPUTS_ON 0x1F
#define FLAGS_FORWARD 0x20
#define FLAGS_FAULTS 0x0F              /* written as 0: the fault latch is cleared */

static uint8_t regs[SIL_PORTS][256], reg_ptr[SIL_PORTS], fault_regs[SIL_PORTS][3];
static int16_t drive_seen[SIL_PORTS];
static uint8_t drive_mode_seen[SIL_PORTS];   /* 0 coast (outputs off), 1 driven */
/* Ports whose drive changes stop the firmware at once (the world's choice): a motor's shaft
 * or a device that reacts to its power must see the change as it happens; a light or an empty
 * port only needs the event, with its time, at the next stop (a ramp changes the duty every
 * millisecond). */
static uint8_t drive_stops = 0xff;

void sil_i2c_set_drive_stops(uint8_t mask) { drive_stops = mask; }

void sil_i2c_set_fault_regs(int port, const uint8_t *regs3) {
    if (port >= 0 && port < SIL_PORTS) memcpy(fault_regs[port], regs3, 3);
}

/* Drive as the driver's flag register (outputs on, direction) and duty set it. */
static void drive_changed(int port) {
    uint8_t flags = regs[port][REG_FLAGS];
    int on = (flags & FLAGS_OUTPUTS_ON) == FLAGS_OUTPUTS_ON;
    uint8_t duty_reg = regs[port][REG_DUTY];
    int16_t duty = on ? (int16_t)((flags & FLAGS_FORWARD) ? duty_reg : -(int)duty_reg) : 0;
    uint8_t mode = (uint8_t)on;
    if (duty == drive_seen[port] && mode == drive_mode_seen[port]) return;
    drive_seen[port] = duty;
    drive_mode_seen[port] = mode;
    sil_world->drive(port, sil_now, duty, on);
    if (drive_stops & (1u << port)) sil_request_yield();
}

static void driver_write(int port, uint8_t reg, uint8_t value) {
    regs[port][reg] = value;
    if (reg == REG_RESET && (value & 1)) {
        memset(regs[port], 0, sizeof regs[port]);
        drive_changed(port);
    } else if (reg == REG_FLAGS) {
        if ((value & FLAGS_FAULTS) == 0) sil_world->faults_cleared(port, sil_now);
        drive_changed(port);
    } else if (reg == REG_DUTY) {
        drive_changed(port);
    }
}

static uint8_t driver_read(int port, uint8_t reg) {
    if (reg == REG_ID_PINS) return sil_gpio_id_pins(port);
    if (reg >= REG_FAULTS && reg <= REG_FAULTS_LAST) return fault_regs[port][reg - REG_FAULTS];
    return regs[port][reg];
}

static int is_accelerometer(const i2c_inst_t *i2c, uint8_t addr) {
    return i2c->bus == ACCEL_BUS && addr == ACCEL_ADDR;
}

i2c_inst_t sil_i2c[2] = {{0}, {1}};

uint i2c_init(i2c_inst_t *i2c, uint baudrate) { (void)i2c; sil_touch(); return baudrate; }
void i2c_deinit(i2c_inst_t *i2c) { (void)i2c; sil_touch(); }

/* A write: the register number, then bytes to it and the registers after it. */
int i2c_write_timeout_us(i2c_inst_t *i2c, uint8_t addr, const uint8_t *src, size_t len, bool nostop,
                         uint timeout_us) {
    (void)nostop; (void)timeout_us;
    sil_touch();
    sil_spend((uint64_t)(len + 1) * I2C_NS_PER_BYTE);
    int port = board_port_of_driver(i2c->bus, addr);
    if (port < 0) return is_accelerometer(i2c, addr) ? (int)len : PICO_ERROR_GENERIC;
    if (len == 0) return 0;
    reg_ptr[port] = src[0];
    for (size_t i = 1; i < len; i++) driver_write(port, reg_ptr[port]++, src[i]);
    return (int)len;
}

/* A read: bytes from the register a write named, and the registers after it. */
int i2c_read_timeout_us(i2c_inst_t *i2c, uint8_t addr, uint8_t *dst, size_t len, bool nostop,
                        uint timeout_us) {
    (void)nostop; (void)timeout_us;
    sil_touch();
    sil_spend((uint64_t)(len + 1) * I2C_NS_PER_BYTE);
    int port = board_port_of_driver(i2c->bus, addr);
    if (port < 0) {
        if (!is_accelerometer(i2c, addr)) return PICO_ERROR_GENERIC;
        memset(dst, 0, len);
        return (int)len;
    }
    for (size_t i = 0; i < len; i++) dst[i] = driver_read(port, reg_ptr[port]++);
    return (int)len;
}

int i2c_write_blocking(i2c_inst_t *i2c, uint8_t addr, const uint8_t *src, size_t len, bool nostop) {
    return i2c_write_timeout_us(i2c, addr, src, len, nostop, 0);
}

int i2c_read_blocking(i2c_inst_t *i2c, uint8_t addr, uint8_t *dst, size_t len, bool nostop) {
    return i2c_read_timeout_us(i2c, addr, dst, len, nostop, 0);
}
