// A Build HAT firmware image (firmware.bin) on rp2040js's emulated RP2040, speaking the frames of
// the firmware in the loop (sil/protocol.py) on stdin/stdout, so the world around it is sil's.
//
//   node runner.mjs --rp2040js DIR --bootrom FILE --image FILE [--stock-uart]
//
// DIR holds node_modules/rp2040js (`buildhat-conformance rp2040 setup` installs the pinned version
// there). The image is written into SRAM at 0x20000000 and started at its first word, as the HAT's
// bootloader starts it; the boot ROM is mapped at 0 (the image calls its functions).
// rp2040js's models are used as they are, except where the chip differs in a way this firmware
// meets (rp2040/README.md, "Corrections"); --stock-uart leaves rp2040js's PL011 alone (tests show
// what the correction changes).
// A core that stops (a breakpoint or undefined instruction: the SDK's panic and the unhandled-fault
// handler end there; an instruction rp2040js cannot run) is a crash: one report on stderr, then
// the process ends by SIGABRT, as a crashed firmware in the loop does.
import fs from 'node:fs';
import path from 'node:path';
import { pathToFileURL } from 'node:url';

const args = {};
for (let i = 2; i < process.argv.length; i++) {
  const a = process.argv[i];
  if (a === '--stock-uart') args.stockUart = true;
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

// ---- the chip -----------------------------------------------------------------------------

const mcu = new RP2040();
mcu.logger = new ConsoleLogger(LogLevel.Error, true);
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
  stopped = `the core stopped at a breakpoint (BKPT/UDF #${code}) at PC 0x${(mcu.core.PC >>> 0).toString(16)}`;
};
const warn = mcu.logger.warn.bind(mcu.logger);
mcu.logger.warn = (component, message) => {
  if (component === 'CortexM0Core' && /not implemented/.test(message)) {
    stopped = `an instruction rp2040js does not implement: ${message}`;
  }
  warn(component, message);
};

// ---- frames -------------------------------------------------------------------------------

const HEADER = 16;
const out = [];
function emit(type, port, t, payload = Buffer.alloc(0)) {
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

// ---- the command port (UART0) -------------------------------------------------------------

const host = mcu.uart[0];
let hostOut = [];            // bytes to the host since the last frame, and when the last ended
let hostOutT = 0;
let yieldWanted = false;
let yieldOnHostIdle = false;
host.onByte = (b) => {
  hostOut.push(b);
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
const hostArrive = clock.createAlarm(() => {
  const [, b] = hostIn.shift();
  host.feedByte(b);
  if (hostIn.length) hostArrive.schedule(Math.max(0, hostIn[0][0] - clock.nanos));
});
function hostBytes(t, bytes) {
  const byteNs = host.baudDivider ? Math.round(10 * 1e9 / host.baudRate) : 86806;
  let end = Math.max(t, hostInEnd, clock.nanos);
  for (const b of bytes) {
    end += byteNs;
    hostIn.push([end, b]);
  }
  hostInEnd = end;
  if (!hostArrive.scheduled) hostArrive.schedule(Math.max(0, hostIn[0][0] - clock.nanos));
}
function flushHost() {
  if (hostOut.length) {
    emit('h', 0, hostOutT, Buffer.from(hostOut));
    hostOut = [];
  }
}
function hostStatus() {
  const rxIdle = hostIn.length === 0 && host.rxFIFO.empty;
  return (hostTxIdle() ? 1 : 0) | (rxIdle ? 2 : 0);
}

// ---- running ------------------------------------------------------------------------------

let limit = 0;
function run() {
  const { core } = mcu;
  while (clock.nanos < limit && !yieldWanted && stopped === null) {
    if (core.waiting) {
      const next = clock.nextAlarm ? clock.nanosToNextAlarm : Infinity;
      clock.tick(Math.max(1, Math.min(next, limit - clock.nanos)));
    } else {
      const cycles = core.executeInstruction();
      clock.tick(cycles * 1e9 / mcu.clkSys);
    }
    if (hostOut.length >= 4096) flushHost();
  }
  yieldWanted = false;
  flushHost();
  if (stopped !== null) {
    flush();
    process.stderr.write(`rp2040: ${stopped} (virtual time ${(clock.nanos / 1e6).toFixed(3)} ms)\n`);
    process.kill(process.pid, 'SIGABRT');
  }
  emit('y', 0, clock.nanos, Buffer.from([hostStatus()]));
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
      case 'R':
        limit = t;
        yieldOnHostIdle = len > 0 && (payload[0] & 1) === 1;
        return;
      case 'H': hostBytes(t, payload); break;
      case 'S': mcu.sram.set(payload.subarray(0, 256), 0x3ff00); break;
      case 'Q': flush(); process.exit(0); break;
      case 'K': {      // a copy of a running chip: not available here (the harness starts a new one)
        const e = Buffer.alloc(4);
        e.writeInt32LE(-38);
        emit('k', 0, clock.nanos, e);
        flush();
        break;
      }
      default:         // the world's frames for the ports: not yet at the chip's pins
        break;
    }
  }
}

emit('y', 0, 0, Buffer.from('SIL1'));
flush();
for (;;) {
  obey();
  run();
}
