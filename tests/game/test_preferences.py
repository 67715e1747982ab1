"""Settings and high scores persist; a damaged file means defaults and a notice."""

import json

from game.preferences import Preferences, Score, add_score, load_preferences, load_scores, save_preferences


def test_preferences_round_trip(tmp_path):
    prefs = Preferences(input="keyboard", side="left", volume=0.3, fullscreen=True)
    save_preferences(prefs, tmp_path)
    assert load_preferences(tmp_path) == (prefs, "")
    assert [p.name for p in tmp_path.iterdir()] == ["settings.json"]


def test_missing_damaged_or_wrong_settings_mean_defaults(tmp_path):
    assert load_preferences(tmp_path) == (Preferences(), "")
    (tmp_path / "settings.json").write_text("{oops")
    prefs, notice = load_preferences(tmp_path)
    assert prefs == Preferences() and "damaged" in notice
    (tmp_path / "settings.json").write_text(json.dumps({"volume": 7}))
    prefs, notice = load_preferences(tmp_path)
    assert prefs == Preferences() and "bad value" in notice


def test_high_scores_keep_the_best_ten_in_order(tmp_path):
    table = []
    for k in range(12):
        table, rank = add_score(table, Score("p", 100 * k, 1), tmp_path)
    assert [s.score for s in table] == [1100 - 100 * k for k in range(10)]
    table, rank = add_score(table, Score("low", 5, 1), tmp_path)
    assert rank is None
    loaded, notice = load_scores(tmp_path)
    assert loaded == table and notice == ""


def test_damaged_scores_start_a_new_table_with_a_notice(tmp_path):
    (tmp_path / "scores.json").write_text('[{"name": "x"}]')
    scores, notice = load_scores(tmp_path)
    assert scores == [] and "damaged" in notice
