// A Build HAT firmware image (firmware.bin) on rp2040js's emulated RP2040, speaking the frames of
// the firmware in the loop (sil/frames.py) on stdin/stdout, so the world around it is sil's.
//
//   node runner.mjs --rp2040js DIR --bootrom FILE --image FILE [--stock-uart]
//
// DIR holds node_modules/rp2040js (`buildhat-conformance rp2040 setup` installs the pinned version
// there). The image is written into SRAM at 0x20000000 and started at its first word, as the HAT's
// bootloader starts it; the boot ROM is mapped at 0 (the image calls its functions).
// rp2040js's models are used as they are, except where the chip differs in a way this firmware
// meets (rp2040/README.md, "Corrections"); --stock-uart and --stock-nvic leave rp2040js's PL011 and
// NVIC alone (tests show what each correction changes); --no-idle-skip runs every instruction of
// the firmware's idle polling (tests show that skipping it changes nothing the world sees).
// A core that stops (a breakpoint or undefined instruction: the SDK's panic and the unhandled-fault
// handler end there; an access where nothing answers, a bus fault on the chip; an instruction
// rp2040js cannot run) is a crash: one report on stderr, then
// the process ends by SIGABRT, as a crashed firmware in the loop does.
import fs from 'node:fs';
import path from 'node:path';
import { pathToFileURL } from 'node:url';

const args = {};
for (let i = 2; i < process.argv.length; i++) {
  const a = process.argv[i];
  if (a === '--stock-uart') args.stockUart = true;
  else if (a === '--stock-nvic') args.stockNvic = true;
  else if (a === '--no-idle-skip') args.noIdleSkip = true;
  else if (a.startsWith('--')) args[a.slice(2)] = process.argv[++i];
}
for (const need of ['rp2040js', 'bootrom', 'image']) {
  if (!args[need]) {
    process.stderr.write(`rp2040 runner: --${need} is missing\n`);
    process.exit(2);
  }
}
const lib = pathToFileURL(path.join(args.rp2040js, 'node_modules/rp2040js/dist/esm/'));
const { RP2040 } = await import(new URL('index.js', lib));
const { RPUART } = await import(new URL('peripherals/uart.js', lib));
const { ConsoleLogger, LogLevel } = await import(new URL('index.js', lib));

const SRAM = 0x20000000;
const UARTDR = 0x0, UARTFR = 0x18, UARTLCR_H = 0x2c, UARTCR = 0x30, UARTIFLS = 0x34;
const UARTIMSC = 0x38, UARTRIS = 0x3c, UARTMIS = 0x40, UARTICR = 0x44;
const TXINT = 1 << 5;

// ---- corrections --------------------------------------------------------------------------

// The PL011 transmitter as the chip has it (ARM PL011 TRM, "UARTTXINTR"; RP2040 datasheet 4.2):
// a holding register (the FIFO, 1 deep when FIFOs are off, else 32) in front of a shift register.
// A byte moves into the shifter when it is free and leaves the wire 10 bit times later. The
// transmit interrupt is raised when the holding register empties (FIFOs on: falls to the trigger
// level) and is cleared by writing the interrupt-clear register or the data register. rp2040js
// raises it on every check whatever the firmware does, so a handler that clears it runs forever.
class ChipUART extends RPUART {
  constructor(rp2040, name, irq, dreq) {
    super(rp2040, name, irq, dreq);
    this.txQueue = [];
    this.shifting = false;
    this.ifls = 0x12;
    this.shiftDone = rp2040.clock.createAlarm(() => this.byteLeft());
  }
  get txDepth() { return this.fifosEnabled ? 32 : 1; }
  get txLevel() {   // FIFOs on: the interrupt rises when the FIFO falls to this many bytes
    return [4, 8, 16, 24, 28][Math.min(this.ifls & 7, 4)];
  }
  get byteNanos() {
    const baud = this.baudDivider ? this.baudRate : 115200;
    return Math.round((1 + this.wordLength + 1) * 1e9 / baud);
  }
  get flags() {
    const full = this.txQueue.length >= this.txDepth;
    return (this.rxFIFO.full ? 1 << 6 : 0) | (this.rxFIFO.empty ? 1 << 4 : 0)
      | (this.txQueue.length === 0 ? 1 << 7 : 0) | (full ? 1 << 5 : 0)
      | (this.shifting || this.txQueue.length ? 1 << 3 : 0);
  }
  checkInterrupts() {
    this.rp2040.setInterrupt(this.irq, !!(this.interruptStatus & this.interruptMask));
  }
  startShift() {
    this.txQueue.shift();
    this.shifting = true;
    this.shiftDone.schedule(this.byteNanos);
    const left = this.txQueue.length;
    if (this.fifosEnabled ? left === this.txLevel : left === 0) this.interruptStatus |= TXINT;
  }
  byteLeft() {
    this.shifting = false;
    this.onByte?.(this.sending);
    if (this.txQueue.length) {
      this.sending = this.txQueue[0];
      this.startShift();
    }
    this.onTxIdle?.();
    this.checkInterrupts();
  }
  readUint32(offset) {
    switch (offset) {
      case UARTFR: return this.flags;
      case UARTIFLS: return this.ifls;
      case UARTRIS: return this.interruptStatus;
      case UARTMIS: return this.interruptStatus & this.interruptMask;
    }
    return super.readUint32(offset);
  }
  writeUint32(offset, value) {
    switch (offset) {
      case UARTDR:
        this.interruptStatus &= ~TXINT;
        if (this.txQueue.length < this.txDepth) {    // a write to a full FIFO is lost, as on the chip
          this.txQueue.push(value & 0xff);
          if (!this.shifting) {
            this.sending = value & 0xff;
            this.startShift();
          }
        }
        this.checkInterrupts();
        return;
      case UARTIFLS:
        this.ifls = value & 0x3f;
        return;
      case UARTICR:
        this.interruptStatus &= ~this.rawWriteValue;
        this.checkInterrupts();
        this.onTxIdle?.();
        return;
    }
    super.writeUint32(offset, value);
  }
}

// The NVIC as ARMv6-M has it (ARMv6-M ARM B3.4; RP2040 datasheet 2.3.2): taking an interrupt
// clears its pending bit; a peripheral that still holds its line high pends it again. rp2040js
// keeps a hardware interrupt pending until the peripheral lowers its line, so one pended from
// software (NVIC_ISPR, as the firmware does to start sending) enters its handler again and again
// while the line is low.
function correctNvic(core) {
  const level = new Array(32).fill(false);
  const set = core.setInterrupt.bind(core);
  core.setInterrupt = (irq, value) => {
    level[irq] = value;
    set(irq, value);
  };
  const entry = core.exceptionEntry.bind(core);
  core.exceptionEntry = (n) => {
    entry(n);
    const irq = n - 16;
    if (irq >= 0 && irq < 32 && !level[irq]) core.pendingInterrupts &= ~(1 << irq);
  };
}

// ---- the chip -----------------------------------------------------------------------------

const mcu = new RP2040();
mcu.logger = new ConsoleLogger(LogLevel.Error, true);
if (!args.stockNvic) correctNvic(mcu.core);
if (!args.stockUart) {
  const [u0, u1] = mcu.uart;
  mcu.uart = [new ChipUART(mcu, 'UART0', u0.irq, u0.dreq), new ChipUART(mcu, 'UART1', u1.irq, u1.dreq)];
  mcu.peripherals[0x40034] = mcu.uart[0];
  mcu.peripherals[0x40038] = mcu.uart[1];
}
const clock = mcu.clock;
mcu.loadBootrom(new Uint32Array(toArrayBuffer(fs.readFileSync(args.bootrom))));
const image = fs.readFileSync(args.image);
mcu.sram.set(image, 0);
mcu.core.PC = SRAM;          // the bootloader jumps to the image's first word (its entry code sets
                             // VTOR, the stack pointer and branches to the reset handler)

function toArrayBuffer(buf) {
  const out = new ArrayBuffer(buf.length & ~3);
  new Uint8Array(out).set(buf.subarray(0, out.byteLength));
  return out;
}

let stopped = null;          // why the core stopped, once it has
mcu.onBreak = (code) => {
  // (the core has moved past the instruction's first halfword when it reports it)
  stopped = `the core stopped at a breakpoint (BKPT/UDF #${code}) at PC 0x${((mcu.core.PC - 2) >>> 0).toString(16)}`;
};
const warn = mcu.logger.warn.bind(mcu.logger);
mcu.logger.warn = (component, message) => {
  if (component === 'CortexM0Core' && /not implemented/.test(message)) {
    stopped = `an instruction rp2040js does not implement: ${message}`;
  } else if (component === 'RP2040' && /invalid memory address|undefined address/.test(message)) {
    // nothing answers at that address: a bus fault on the chip, so a HardFault
    stopped = `HardFault: a bus fault (${message}) at PC 0x${(mcu.core.PC >>> 0).toString(16)}`;
  }
  warn(component, message);
};

// ---- frames -------------------------------------------------------------------------------

// The frame types, one letter each (upper case from the world, lower case to it), named as in
// sil/frames.py (FrameType) and sil/standin/frame_types.h; tests/sil/test_frames.py checks the three agree.
const FRAME = Object.freeze({
  // world -> firmware
  RUN: 'R',
  HOST_BYTES: 'H',
  PORT_BYTES: 'P',
  PORT_CUT: 'C',
  ID_LINES: 'I',
  FAULT_PINS: 'G',
  FAULT_REGS: 'F',
  ADC: 'A',
  DRIVE_STOPS: 'W',
  SIGNATURE: 'S',
  QUIT: 'Q',
  COPY: 'K',
  // firmware -> world
  YIELD: 'y',
  COPY_MADE: 'k',
  TO_HOST: 'h',
  TO_PORT: 'p',
  RECEIVER: 'u',
  DRIVE: 'd',
  FAULTS_CLEARED: 'f',
  POWER: 'o',
  LEDS: 'l',
  BYTE_LOST: 'r',
});

const HEADER = 16;
const out = [];
function emit(type, port, t, payload = Buffer.alloc(0)) {
  touched = true;
  const h = Buffer.alloc(HEADER);
  h.writeUInt8(type.charCodeAt(0), 0);
  h.writeUInt8(port, 1);
  h.writeUInt16LE(payload.length, 2);
  h.writeBigUInt64LE(BigInt(Math.max(0, Math.round(t))), 8);
  out.push(h, payload);
}
function flush() {
  const buf = Buffer.concat(out);
  out.length = 0;
  let off = 0;
  while (off < buf.length) {
    try {
      off += fs.writeSync(1, buf, off);
    } catch (e) {
      if (e.code === 'EAGAIN') continue;
      process.exit(0);        // the world has gone
    }
  }
}
let inbuf = Buffer.alloc(0);
function readExactly(n) {
  while (inbuf.length < n) {
    const chunk = Buffer.alloc(65536);
    let k;
    try {
      k = fs.readSync(0, chunk, 0, chunk.length, null);
    } catch (e) {
      if (e.code === 'EAGAIN') continue;
      throw e;
    }
    if (k === 0) process.exit(0);
    inbuf = Buffer.concat([inbuf, chunk.subarray(0, k)]);
  }
  const got = inbuf.subarray(0, n);
  inbuf = inbuf.subarray(n);
  return got;
}


// ---- the board around the chip: where the Build HAT wires things (facts of its schematic) ------

const PORTS = [      // each port's UART pins and its motor driver on I2C
  { rx: 10, tx: 11, bus: 0, addr: 0x60 },
  { rx: 4, tx: 5, bus: 0, addr: 0x68 },
  { rx: 24, tx: 25, bus: 1, addr: 0x70 },
  { rx: 20, tx: 21, bus: 1, addr: 0x78 },
];
const PIN_LED0 = 14, PIN_LED1 = 15, PIN_PORTFAULT = 16, PIN_PORTON = 17, PIN_MOTORFAULT = 28;
const ADC_VIN = 3;
const FUNC_SIO = 5;
const world = {
  portOk: 1, motorOk: 1,
  ids: PORTS.map(() => ({ signature: 0, rxIdle: 1 })),
  faultRegs: PORTS.map(() => [0, 0, 0]),
  driveStops: 0xff,
};

// How the firmware biases a line: driven low 0, pulled down 1, driven high 2, pulled up 3,
// floating -1 (the ID lines' electrical model, as sil's stand-in reads it).
function lineBias(g) {
  const pin = mcu.gpio[g];
  if (pin.outputEnable && pin.functionSelect === FUNC_SIO) return pin.outputValue ? 2 : 0;
  if (pin.pullupEnabled) return 3;
  if (pin.pulldownEnabled) return 1;
  return -1;
}
function idPins(p) {
  const bt = lineBias(PORTS[p].tx), br = lineBias(PORTS[p].rx);
  let k;
  if (bt < 0 && br >= 0) k = br;
  else if (br < 0 && bt >= 0) k = 4 + bt;
  else return 0;
  const sig = world.ids[p].signature;
  return (((sig >> k) & 1) << 6) | (((sig >> (8 + k)) & 1) << 7);
}

// What every input pin reads: the fault pins as the world says (open-drain, pulled up on the
// board), a port's RX line held low by a device that does so, else the pin's own pull.
// rp2040js reads a pin only as set from outside; the chip reads its pull when nothing drives it.
const portOfRx = new Map(PORTS.map((w, p) => [w.rx, p]));
function settlePins() {
  for (const pin of mcu.gpio) {
    let level;
    if (pin.index === PIN_PORTFAULT) level = !!world.portOk;
    else if (pin.index === PIN_MOTORFAULT) level = !!world.motorOk;
    else if (portOfRx.has(pin.index) && world.ids[portOfRx.get(pin.index)].rxIdle === 0) level = false;
    else if (pin.outputEnable) level = pin.outputValue;
    else level = pin.pullupEnabled || !pin.pulldownEnabled && pin.rawInputValue;
    if (level !== pin.rawInputValue) pin.setInputValue(level);
  }
}

// The motor drivers: a register file each. The drive a motor sees comes from the flag register
// (0x4C: outputs on, direction) and the duty (0xA1); 0x4B reads the ID lines; 0x4D-0x4F the fault
// registers the world sets; a soft reset (0xF5 bit 0) clears the file.
const regs = PORTS.map(() => new Uint8Array(256));
const regPtr = PORTS.map(() => 0);
const driveSeen = PORTS.map(() => [0, 0]);
function driveChanged(p) {
  const flags = regs[p][0x4c];
  const on = (flags & 0x1f) === 0x1f;
  const duty = on ? (flags & 0x20 ? regs[p][0xa1] : -regs[p][0xa1]) : 0;
  const mode = on ? 1 : 0;
  if (duty === driveSeen[p][0] && mode === driveSeen[p][1]) return;
  driveSeen[p] = [duty, mode];
  const msg = Buffer.alloc(3);
  msg.writeInt16LE(duty, 0);
  msg.writeUInt8(mode, 2);
  emit(FRAME.DRIVE, p, clock.nanos, msg);
  if (world.driveStops & (1 << p)) yieldWanted = true;
}
function driverWrite(p, r, v) {
  regs[p][r] = v;
  if (r === 0xf5 && (v & 1)) {
    regs[p].fill(0);
    driveChanged(p);
  } else if (r === 0x4c) {
    if ((v & 0x0f) === 0) emit(FRAME.FAULTS_CLEARED, p, clock.nanos);
    driveChanged(p);
  } else if (r === 0xa1) {
    driveChanged(p);
  }
}
function driverRead(p, r) {
  if (r === 0x4b) return idPins(p);
  if (r >= 0x4d && r <= 0x4f) return world.faultRegs[p][r - 0x4d];
  return regs[p][r];
}
const ACCEL = 0x6a;          // the accelerometer on I2C0: answers, reads zeros
mcu.i2c.forEach((bus, busIndex) => {
  let port = -1, first = false, present = false;
  bus.onConnect = (address) => {
    port = PORTS.findIndex((w) => w.bus === busIndex && w.addr === address);
    present = port >= 0 || (busIndex === 0 && address === ACCEL);
    first = true;
    bus.completeConnect(present);
  };
  bus.onWriteByte = (value) => {
    if (port >= 0) {
      if (first) regPtr[port] = value;
      else driverWrite(port, regPtr[port]++ & 0xff, value);
    }
    first = false;
    bus.completeWrite(present);
  };
  bus.onReadByte = () => {
    first = false;
    bus.completeRead(port >= 0 ? driverRead(port, regPtr[port]++ & 0xff) : 0);
  };
});

// Port power and the LEDs, as the world hears of them.
let powerSeen = -1, ledsSeen = -1;
function outputsChanged() {
  const power = mcu.gpio[PIN_PORTON].outputEnable && mcu.gpio[PIN_PORTON].outputValue ? 1 : 0;
  if (power !== powerSeen && powerSeen !== -1 || power && powerSeen === -1) {
    emit(FRAME.POWER, 0, clock.nanos, Buffer.from([power]));
    yieldWanted = true;
  }
  powerSeen = power;
  const leds = (mcu.gpio[PIN_LED0].outputValue ? 1 : 0) | (mcu.gpio[PIN_LED1].outputValue ? 2 : 0);
  if (leds !== ledsSeen) emit(FRAME.LEDS, 0, clock.nanos, Buffer.from([leds]));
  ledsSeen = leds;
}
for (const pin of mcu.gpio) {
  pin.addListener(() => {
    touched = true;
    outputsChanged();
    settlePins();
  });
}
mcu.adc.channelValues[ADC_VIN] = 0;

// ---- the command port (UART0) -------------------------------------------------------------

const host = mcu.uart[0];
let hostOut = [];            // bytes to the host since the last frame, and when the last ended
let hostOutT = 0;
let yieldWanted = false;
let yieldOnHostIdle = false;
host.onByte = (b) => {
  hostOut.push(b);
  touched = true;
  hostOutT = clock.nanos;
};
host.onTxIdle = () => {
  if (yieldOnHostIdle && hostTxIdle()) yieldWanted = true;    // the answer is complete for now
};
function hostTxIdle() {
  if (args.stockUart) return true;
  return !host.shifting && host.txQueue.length === 0 && !(host.interruptStatus & host.interruptMask & TXINT);
}
const hostIn = [];           // [time, byte] not yet on the wire, in order
let hostInEnd = 0;           // when the last queued byte finishes arriving
// (rp2040js leaves an alarm marked scheduled after it fired: the queue says whether one is due)
const hostArrive = clock.createAlarm(() => {
  const [, b] = hostIn.shift();
  host.feedByte(b);
  if (hostIn.length) hostArrive.schedule(Math.max(0, hostIn[0][0] - clock.nanos));
});
function hostBytes(t, bytes) {
  const byteNs = host.baudDivider ? Math.round(10 * 1e9 / host.baudRate) : 86806;
  const idle = hostIn.length === 0;
  let end = Math.max(t, hostInEnd, clock.nanos);
  for (const b of bytes) {
    end += byteNs;
    hostIn.push([end, b]);
  }
  hostInEnd = end;
  if (idle && hostIn.length) hostArrive.schedule(Math.max(0, hostIn[0][0] - clock.nanos));
}
function flushHost() {
  if (hostOut.length) {
    emit(FRAME.TO_HOST, 0, hostOutT, Buffer.from(hostOut));
    hostOut = [];
  }
}
function hostStatus() {
  const rxIdle = hostIn.length === 0 && host.rxFIFO.empty;
  return (hostTxIdle() ? 1 : 0) | (rxIdle ? 2 : 0);
}

// ---- running ------------------------------------------------------------------------------

// Idle time is skipped as sil's stand-in skips it (sil/README.md, "How time works"), with one
// generalisation: this firmware's main loop reads the timer more than once a pass (once per port),
// so a pass is a run of timer reads. When the intervals (in instructions) between the last 2P reads
// repeat with a period P of up to 8 reads and nothing outside the core happened during them (no
// interrupt taken, no write to a peripheral, nothing sent to the world), the main loop is polling; the clock then jumps to
// the next event (a peripheral's alarm, a byte arriving, the run's limit) or to the next
// millisecond edge of the timer, never past it, so a loop waiting for a tick value still sees
// every tick. A pass shorter than MIN_PASS instructions is a busy wait, never skipped.
const MAX_PERIOD = 8;
const MIN_PASS = 100;        // instructions: shorter loops wait for a time in microseconds (the SDK's
                             // busy_wait, an I2C timeout) and must see it as it comes
let executed = 0;            // instructions since power-on
let touched = true;          // something outside the core happened since the last timer read
let lastRead = 0;
const intervals = [];        // between the last timer reads, newest last, each -1 if touched
let skipTo = 0;              // > now: jump the clock there before the next instruction
const timer = mcu.peripherals[0x40054];
const timerRead = timer.readUint32.bind(timer);
const TIMELR = 0x0c, TIMERAWL = 0x28;
function polling() {
  const n = intervals.length;
  for (let period = 1; period <= MAX_PERIOD && 2 * period <= n; period++) {
    let same = true, pass = 0;
    for (let i = n - period; i < n && same; i++) {
      same = intervals[i] >= 0 && intervals[i] === intervals[i - period] && intervals[i - period] >= 0;
      pass += intervals[i];
    }
    if (same) return pass >= MIN_PASS;
  }
  return false;
}
timer.readUint32 = (offset) => {
  if (offset === TIMELR || offset === TIMERAWL) {
    intervals.push(touched ? -1 : executed - lastRead);
    if (intervals.length > 2 * MAX_PERIOD) intervals.shift();
    if (!args.noIdleSkip && polling()) {
      const edge = (Math.floor(clock.nanos / 1e6) + 1) * 1e6;
      skipTo = Math.min(edge, clock.nextAlarm ? clock.nextAlarm.nanos : Infinity, limit);
    }
    lastRead = executed;
    touched = false;
  }
  return timerRead(offset);
};
// A write to a peripheral changes the world, except the pins' (SIO, IO and pads): a pin that
// changes says so through its listener (below), and writing a pin's state again changes nothing
// (the main loop biases the ID lines of the empty ports every pass).
const quietPeripheral = (a) => a >= 0xd0000000 || (a >= 0x40014000 && a < 0x40018000)
  || (a >= 0x4001c000 && a < 0x40020000);
for (const name of ['writeUint32', 'writeUint16', 'writeUint8']) {
  const write = mcu[name].bind(mcu);
  mcu[name] = (address, value) => {
    const a = address >>> 0;
    if (a >= 0x40000000 && !quietPeripheral(a)) touched = true;
    write(address, value);
  };
}
const entry = mcu.core.exceptionEntry.bind(mcu.core);
mcu.core.exceptionEntry = (n) => {
  touched = true;
  entry(n);
};

let limit = 0;
function run() {
  const { core } = mcu;
  const instrNanos = () => 1e9 / mcu.clkSys;
  let step = instrNanos();
  let clkSys = mcu.clkSys;
  while (clock.nanos < limit && !yieldWanted && stopped === null) {
    if (core.waiting) {
      const next = clock.nextAlarm ? clock.nanosToNextAlarm : Infinity;
      clock.tick(Math.max(1, Math.min(next, limit - clock.nanos)));
      continue;
    }
    if (skipTo > clock.nanos) {
      clock.tick(skipTo - clock.nanos);
      skipTo = 0;
    }
    const cycles = core.executeInstruction();
    executed++;
    if (mcu.clkSys !== clkSys) {
      clkSys = mcu.clkSys;
      step = instrNanos();
    }
    clock.tick(cycles * step);
    if (hostOut.length >= 4096) flushHost();
  }
  yieldWanted = false;
  flushHost();
  if (stopped !== null) {
    flush();
    process.stderr.write(`rp2040: ${stopped} (virtual time ${(clock.nanos / 1e6).toFixed(3)} ms)\n`);
    process.kill(process.pid, 'SIGABRT');
  }
  emit(FRAME.YIELD, 0, clock.nanos, Buffer.from([hostStatus()]));
  flush();
}

function obey() {
  for (;;) {
    const h = readExactly(HEADER);
    const type = String.fromCharCode(h.readUInt8(0));
    const len = h.readUInt16LE(2);
    const t = Number(h.readBigUInt64LE(8));
    const payload = readExactly(len);
    switch (type) {
      case FRAME.RUN:
        limit = t;
        yieldOnHostIdle = len > 0 && (payload[0] & 1) === 1;
        return;
      case FRAME.HOST_BYTES: hostBytes(t, payload); break;
      case FRAME.SIGNATURE: mcu.sram.set(payload.subarray(0, 256), 0x3ff00); break;
      case FRAME.ID_LINES:
        if (len >= 3) world.ids[h.readUInt8(1)] = { signature: payload.readUInt16LE(0), rxIdle: payload[2] };
        settlePins();
        break;
      case FRAME.FAULT_PINS:
        if (len >= 2) [world.portOk, world.motorOk] = [payload[0], payload[1]];
        settlePins();
        break;
      case FRAME.FAULT_REGS: if (len >= 3) world.faultRegs[h.readUInt8(1)] = [...payload.subarray(0, 3)]; break;
      case FRAME.ADC: if (len >= 2) mcu.adc.channelValues[ADC_VIN] = payload.readUInt16LE(0); break;
      case FRAME.DRIVE_STOPS: if (len >= 1) world.driveStops = payload[0]; break;
      case FRAME.QUIT: flush(); process.exit(0); break;
      case FRAME.COPY: {      // a copy of a running chip: not available here (the harness starts a new one)
        const e = Buffer.alloc(4);
        e.writeInt32LE(-38);
        emit(FRAME.COPY_MADE, 0, clock.nanos, e);
        flush();
        break;
      }
      default:         // the world's frames for the ports: not yet at the chip's pins
        break;
    }
  }
}

settlePins();
emit(FRAME.YIELD, 0, 0, Buffer.from('SIL1'));
flush();
for (;;) {
  obey();
  run();
}
