// A Build HAT client in the style of a Node.js host library (written from issue 14's
// description only): it opens the serial device, checks the firmware with `version`, sends
// `list`, and does not proceed until the `deltat=XXXXXXXX` line that follows the list on a real
// HAT. Standard library only. Usage: node list_then_deltat.js DEVICE [TIMEOUT_MS]
// Prints one JSON line {version, listLines, deltat, vin} and exits 0, or names what it waited
// for and exits 1.
"use strict";
const fs = require("fs");
const tty = require("tty");

const device = process.argv[2];
const timeoutMs = Number(process.argv[3] || 10000);
if (!device) {
  console.error("usage: node list_then_deltat.js DEVICE [TIMEOUT_MS]");
  process.exit(2);
}

const fd = fs.openSync(device, fs.constants.O_RDWR | fs.constants.O_NOCTTY);
const input = new tty.ReadStream(fd);
input.setRawMode(true);

let buffer = "";
let waiter = null;          // {test, resolve, what}
const lines = [];

input.on("data", (chunk) => {
  buffer += chunk.toString("latin1");
  let at;
  while ((at = buffer.indexOf("\r\n")) >= 0) {
    const line = buffer.slice(0, at);
    buffer = buffer.slice(at + 2);
    lines.push(line);
    if (waiter && waiter.test(line)) {
      const w = waiter;
      waiter = null;
      w.resolve(line);
    }
  }
});

function send(text) {
  fs.writeSync(fd, text + "\r");
}

function waitFor(what, test) {
  return new Promise((resolve, reject) => {
    const timer = setTimeout(() => reject(new Error("timed out waiting for " + what)), timeoutMs);
    waiter = { what, test, resolve: (line) => { clearTimeout(timer); resolve(line); } };
  });
}

async function main() {
  let version = null;
  for (let attempt = 0; attempt < 5 && version === null; attempt++) {
    const reply = waitFor("the version line", (l) => l.startsWith("Firmware version: "));
    send("version");
    try { version = await reply; } catch (e) { waiter = null; }
  }
  if (version === null) throw new Error("no Firmware version line after 5 tries");
  const start = lines.length;
  const stall = waitFor("a deltat= line after list", (l) => /^deltat=[0-9A-F]{8}$/.test(l));
  send("list");
  const deltat = await stall;              // the library does not proceed before this line
  const listLines = lines.slice(start).filter((l) => /^P[0-3]: /.test(l));
  const vin = waitFor("the vin line", (l) => / V$/.test(l));
  send("vin");
  console.log(JSON.stringify({ version, listLines, deltat, vin: await vin }));
}

main().then(() => process.exit(0),
            (err) => { console.error("client: " + err.message); process.exit(1); });
