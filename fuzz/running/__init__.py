"""Running a campaign: seeded checked runs under a budget, workers, places, signals, the target exchange."""
