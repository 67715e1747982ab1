"""The README's promises: a two-command quick start, the test command CI runs."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def quick_start_commands() -> list[str]:
    readme = (ROOT / "README.md").read_text()
    section = readme.split("## Quick start", 1)[1].split("\n## ", 1)[0]
    blocks = re.findall(r"```sh\n(.*?)```", section, flags=re.S)
    return [line for block in blocks[:2] for line in block.strip().splitlines()]


def test_quick_start_is_exactly_two_commands_install_and_play_then_install_and_test():
    play, test = quick_start_commands()
    assert "pip install" in play and play.endswith("energyball")
    assert "'.[test," in test and "pytest" in test


def test_ci_runs_the_readme_test_command_verbatim():
    _, test = quick_start_commands()
    ci = (ROOT / ".ci" / "run").read_text().splitlines()
    assert test in ci
