"""pytest plugin for host libraries: a ``buildhat_emulator`` fixture (filled in by the emulator's pty runner)."""
