"""The world: the arena, its data and the town (pure logic, no pygame)."""
