"""``--help`` is a user's first contact: a plain description, examples, a pointer to the book, every option's
default."""

from __future__ import annotations

import argparse
import subprocess
import sys

from motionlab.cli import EPILOG, _HelpFormatter, build_parser


def _parsers(parser: argparse.ArgumentParser, path: tuple[str, ...] = ("motionlab",)):
    """Every parser of the command line with its command words, the top level first."""
    yield path, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _parsers(sub, path + (name,))


def test_the_top_level_help_describes_the_tool_and_shows_examples():
    out = subprocess.run([sys.executable, "-m", "motionlab", "--help"], capture_output=True, text=True)
    assert out.returncode == 0
    text = out.stdout
    assert "Generate motion from text" in text and "Thin" not in text and "``" not in text
    assert "examples:" in text and "jupyter lab notebooks/" in text and "_build/html" in text
    # the example lines keep their layout (not re-wrapped into a paragraph)
    assert '\n  motionlab generate "a person waves" --profile smoke --out wave.html' in text
    for line in EPILOG.splitlines():
        if line.startswith("  motionlab "):
            build_parser().parse_args(line.split("#")[0].split()[1:])  # every example parses


def test_every_argument_is_documented_and_every_default_shown():
    undocumented, no_default = [], []
    for path, parser in _parsers(build_parser()):
        assert isinstance(parser.formatter_class, type) and issubclass(parser.formatter_class, _HelpFormatter)
        formatter = parser._get_formatter()
        for action in parser._actions:
            if isinstance(action, (argparse._HelpAction, argparse._VersionAction, argparse._SubParsersAction)):
                continue
            name = f"{' '.join(path)} {action.option_strings or action.dest}"
            if not action.help:
                undocumented.append(name)
            shown = formatter._get_help_string(action) % {"default": action.default}
            valued = action.option_strings and action.default is not None and not isinstance(action.default, bool)
            if valued and "default" not in shown:
                no_default.append(name)
    assert not undocumented, undocumented
    assert not no_default, no_default


def test_generate_help_documents_seed_profile_and_device():
    parser = dict(_parsers(build_parser()))[("motionlab", "generate")]
    text = " ".join(parser.format_help().split())  # unwrapped
    assert "--seed SEED seeds the sampling" in text and "(default: 0)" in text
    assert "$MOTIONLAB_PROFILE or laptop" in text and "only shows that the code runs" in text
    assert "--device DEVICE cpu, cuda" in text and "(default: CUDA when present)" in text
    assert "(default: 120)" in text  # --length's list default, written as on the command line


def test_the_formatter_appends_a_default_once_and_keeps_example_blocks():
    formatter = _HelpFormatter("prog")
    parser = argparse.ArgumentParser()
    plain = parser.add_argument("--n", type=int, default=3, help="how many")
    said = parser.add_argument("--m", type=int, default=3, help="how many (default: three)")
    flag = parser.add_argument("--flag", action="store_true", help="a switch")
    zero = parser.add_argument("--seed", type=int, default=0, help="a seed")
    assert formatter._get_help_string(plain) == "how many (default: %(default)s)"
    assert formatter._get_help_string(zero) == "a seed (default: %(default)s)"  # 0 is shown, though 0 == False
    assert formatter._get_help_string(said) == "how many (default: three)"
    assert formatter._get_help_string(flag) == "a switch"
    text = "examples:\n  a  # one\n  b  # two\n\nA long paragraph\nthat wraps."
    assert formatter._fill_text(text, 80, "") == "examples:\n  a  # one\n  b  # two\n\nA long paragraph that wraps."
