"""``motionlab evaluate``'s options and the configs meet in one table (``evaluation.CLI_OPTIONS``): the CLI builds a
config from exactly those options and a config writes itself back as that command."""

from __future__ import annotations

import argparse
import shlex
from dataclasses import fields

import pytest

from motionlab import cli
from motionlab.evaluation import CLI_OPTIONS, CONFIGS, Option, config_from_options

# options of `evaluate` that are not a config's: where the data and models come from, and where the table goes
NOT_CONFIG = {
    "profile",
    "precision",
    "force_precision",
    "deterministic",
    "compile",
    "threads",
    "data",
    "device",
    "json",
    "force",
    "task",
    "command",
    "func",
}


def _parsed(argv: list[str]):
    return cli.build_parser().parse_args(argv)


@pytest.mark.parametrize("task", sorted(CONFIGS))
def test_the_bare_command_is_the_config_s_defaults(task):
    args = _parsed(["evaluate", task])
    assert cli._evaluation_config(args, repeats=1) == CONFIGS[task](repeats=1)


@pytest.mark.parametrize("task", sorted(CONFIGS))
def test_every_option_is_a_config_field_and_every_field_an_option(task):
    args = vars(_parsed(["evaluate", task]))
    names = {f.name for f in fields(CONFIGS[task])}
    assert set(CLI_OPTIONS[task]) == names
    assert set(args) - NOT_CONFIG == names  # argparse's destinations are the field names


def _task_parser(task: str) -> argparse.ArgumentParser:
    """The parser of ``motionlab evaluate <task>``."""
    parser = cli.build_parser()
    for name in ("evaluate", task):
        parser = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices[name]
    return parser


@pytest.mark.parametrize("task", sorted(CONFIGS))
def test_each_flag_is_the_one_the_parser_knows(task):
    actions = {flag: action for action in _task_parser(task)._actions for flag in action.option_strings}
    for name, option in CLI_OPTIONS[task].items():
        action = actions.get(option.flag)
        assert action is not None and action.dest == name, option.flag
        if option.kind == "switch":
            words = [option.flag]
        else:  # a value the parser accepts that is not the default
            words = [option.flag, next(c for c in action.choices if c != action.default) if action.choices else "1"]
        parsed = _parsed(["evaluate", task, *words])
        assert getattr(parsed, name) != action.default, option.flag  # the value given reached the field


def test_comma_options_parse_into_tuples_and_name_the_flag_when_wrong():
    assert Option("--models", "list").parse("t2m/uniform, t2m/dynamic") == ("t2m/uniform", "t2m/dynamic")
    assert Option("--guidance-scales", "numbers").parse("0,4") == (0.0, 4.0)
    with pytest.raises(ValueError, match="--guidance-scales must be comma-separated numbers"):
        Option("--guidance-scales", "numbers").parse("0,four")
    assert Option("--grid", "grid").words((("euler", 1), ("midpoint", 15))) == ["--grid", "euler:1,midpoint:15"]
    assert Option("--top-p", "value").words(0.85) == ["--top-p", "0.85"]
    assert Option("--jerk", "switch").words(False) == []


@pytest.mark.parametrize(
    "task, changes",
    [
        ("reconstruction", dict(grid=(("euler", 4),), temperature=1.0, jerk=True, limit=8, seed=3)),
        ("t2m", dict(models=("t2m/uniform", "t2m/dynamic"), guidance_scales=(0.0, 4.0), top_p=0.85, limit=40)),
        ("multi", dict(methods=("tps:T_s=50", "independent"), instances=4, T_s=80, segment_jerk=True)),
    ],
)
def test_a_config_s_command_line_parses_back_into_it(task, changes):
    config = CONFIGS[task](repeats=3, **changes)
    argv = shlex.split(config.command_line("smoke"))[1:]
    args = _parsed(argv)
    assert args.profile == "smoke"
    assert config_from_options(task, CONFIGS[task], vars(args)) == config
