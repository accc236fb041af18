"""Grammar-based and stateful fuzzing of a Build HAT target, with a differential mode."""
