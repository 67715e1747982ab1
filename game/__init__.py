"""EnergyBall game: world/ (the arena), body/ (the player), sim/ (simulated players), ui/ (the pygame shell)."""
