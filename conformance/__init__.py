"""The conformance suite: one pytest test per clause, expectations from the spec and the facts."""
