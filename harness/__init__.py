"""The harness: targets (how bytes reach a HAT), sessions (lines and typed events),
transcripts (every byte, timestamped) and scenario scripts."""
