"""The harness: targets (how bytes reach a HAT), sessions (lines and typed events), the transcript
writer (every byte, timestamped) and firmware load through the HAT's bootloader. Scenario scripts
are transcripts/'s."""
