"""One HAT port: its device state machine, the LPF2 conversation with a device, its UART, modes and data
reports.
"""
