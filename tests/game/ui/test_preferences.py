"""Settings and high scores persist; a damaged file means defaults and a notice."""

import json

from game.ui.preferences import Preferences, Score, add_score, load_preferences, load_scores, save_preferences


def test_preferences_round_trip(tmp_path):
    prefs = Preferences(input="keyboard", side="left", volume=0.3, fullscreen=True)
    save_preferences(prefs, tmp_path)
    assert load_preferences(tmp_path) == (prefs, [])
    assert [p.name for p in tmp_path.iterdir()] == ["settings.json"]


def test_missing_damaged_or_wrong_settings_mean_defaults(tmp_path):
    assert load_preferences(tmp_path) == (Preferences(), [])
    (tmp_path / "settings.json").write_text("{oops")
    prefs, notices = load_preferences(tmp_path)
    assert prefs == Preferences() and len(notices) == 1 and "not valid JSON" in notices[0]
    (tmp_path / "settings.json").write_text(json.dumps({"volume": 7, "side": "left"}))
    prefs, notices = load_preferences(tmp_path)
    assert prefs == Preferences(side="left") and len(notices) == 1
    assert "volume must be a number from 0 to 1" in notices[0] and "not 7; using 0.8" in notices[0]


def test_high_scores_keep_the_best_ten_in_order(tmp_path):
    table = []
    for k in range(12):
        table, rank = add_score(table, Score("p", 100 * k, 1), tmp_path)
    assert [s.score for s in table] == [1100 - 100 * k for k in range(10)]
    table, rank = add_score(table, Score("low", 5, 1), tmp_path)
    assert rank is None
    loaded, notices = load_scores(tmp_path)
    assert loaded == table and notices == []


def test_damaged_scores_start_a_new_table_with_a_notice(tmp_path):
    (tmp_path / "scores.json").write_text('[{"name": "x"}]')
    scores, notices = load_scores(tmp_path)
    assert scores == [] and "1 of 1 entries damaged" in notices[0] and "lacks score, wave, date" in notices[0]
