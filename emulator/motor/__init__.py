"""One port's motor: the set-point waveforms, the PID, the PWM drive path and the shaft physics."""
