"""Simulated players: the motion model, the bot, headless matches and gesture evaluation."""
