/* The frame types between the world (sil/frames.py, Python) and the stand-in, one letter each:
 * upper case from the world, lower case to it. The same list is in sil/frames.py (FrameType)
 * and rp2040/runner.mjs (FRAME); tests/sil/test_frames.py checks that the three agree. Each
 * frame's payload is described in sil/frames.py. */
#ifndef SIL_FRAME_TYPES_H
#define SIL_FRAME_TYPES_H

enum sil_frame_type {
    /* world -> firmware */
    FRAME_RUN = 'R',                   /* run until the time given (or the firmware's own stop) */
    FRAME_HOST_BYTES = 'H',            /* bytes from the host on the command port */
    FRAME_PORT_BYTES = 'P',            /* bytes from a port's device */
    FRAME_PORT_CUT = 'C',              /* the device stopped sending */
    FRAME_ID_LINES = 'I',              /* a port's ID lines */
    FRAME_FAULT_PINS = 'G',            /* the two fault pins */
    FRAME_FAULT_REGS = 'F',            /* a port driver's fault registers */
    FRAME_ADC = 'A',                   /* the ADC reading of the input voltage */
    FRAME_DRIVE_STOPS = 'W',           /* ports whose drive changes stop the firmware */
    FRAME_SIGNATURE = 'S',             /* what the bootloader left in RAM */
    FRAME_QUIT = 'Q',                  /* exit */
    FRAME_COPY = 'K',                  /* fork a copy of this HAT */
    /* firmware -> world */
    FRAME_YIELD = 'y',                 /* stopped: the world's turn */
    FRAME_COPY_MADE = 'k',             /* the answer to FRAME_COPY */
    FRAME_TO_HOST = 'h',               /* bytes to the host */
    FRAME_TO_PORT = 'p',               /* a byte to a port's device */
    FRAME_RECEIVER = 'u',              /* a port's receiver switched on or off */
    FRAME_DRIVE = 'd',                 /* a motor driver's output */
    FRAME_FAULTS_CLEARED = 'f',        /* a driver's fault latch cleared */
    FRAME_POWER = 'o',                 /* port power switched */
    FRAME_LEDS = 'l',                  /* the two status LEDs */
    FRAME_BYTE_LOST = 'r',             /* a byte from a device lost: the PIO RX FIFO was full */
};

#endif
