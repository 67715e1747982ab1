"""Session recordings of the game and their replay (README, "Recordings and replays").

:mod:`.samples` packs board samples for a recording; :mod:`.log` is what the
game tells a session as it runs (the recorder writes it, a replay collects
it to compare); :mod:`.reader` reads a recording back frame by frame;
:mod:`.replay` plays one again.
"""
