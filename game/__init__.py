"""EnergyBall game: avatar, gestures, arena, rendering."""
