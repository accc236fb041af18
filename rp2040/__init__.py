"""A release's shipped ``firmware.bin`` on an emulated RP2040 (rp2040js on Node.js), with the world of
the firmware in the loop around it. See README.md in this folder."""
