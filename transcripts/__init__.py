"""Scenarios and transcripts: the scenario-script format, the one script runner, and the commands
that record, replay, compare and mock (``buildhat-conformance script|record|replay|mock``).

The JSONL transcript writer and reader stay in harness/transcript.py: the session writes every
byte as it arrives, below this folder. The example transcripts and their scripts are data
(``transcripts/data/``).
"""
