"""Every numeric flag of every case, and the flags all cases share, refuses 0, a negative value, NaN
and inf while the flags are parsed: one line naming the flag and what it allows, exit code 2, before
any scene is built or any kernel runs (mpmdem.study.flag_types). The values a flag means are listed in
ALLOWED with the reason; the test checks that they parse as given (0 is not "not given")."""

import pytest

from mpmdem.cases import CASES
from mpmdem.study.runner import case_module, make_case_parser

#: 0, a negative value written as argparse would take for a flag (-1e-05, not -1), NaN and inf
VALUES = ("0", "-1e-05", "nan", "inf")

#: (case or "*" for every case, flag, value) → why the value is valid
ALLOWED = {
    ("*", "--damping", "0"): "no Cundall damping (the default)",
    ("*", "--flip-fraction", "0"): "the blended schemes at pure PIC",
    ("block-on-incline", "--friction", "0"): "a frictionless incline",
    ("column-collapse", "--critical-density-ratio", "0"): "no critical density",
    ("column-collapse", "--seed", "0"): "a random seed",
    ("disk-collision", "--restitution", "0"): "a perfectly plastic impact",
    ("disk-collision", "--friction", "0"): "a frictionless pair",
    ("friction-force", "--grid-index", "0"): "the first of the paper's four grids",
    ("normal-force", "--grid-index", "0"): "the first of the paper's four grids",
    ("granular-matrix", "--fines", "0"): "a skeleton without fines",
    ("granular-matrix", "--settle-time", "0"): "the bar starts at once",
    ("granular-matrix", "--seed", "0"): "a random seed",
    ("pentagon-pile", "--seed", "0"): "a random seed",
    ("rod-collision", "--offset", "0"): "the first contact on a grid line",
    ("rotating-disk", "--omega", "-1e-05"): "a clockwise spin",
    ("sand-blocks", "--sphero-radius", "0"): "sharp corners",
    ("sand-blocks", "--ensemble-seed", "0"): "a random seed",
    ("sand-blocks", "--seed", "0"): "a random seed",
    ("silo-discharge", "--seed", "0"): "a random seed",
    ("silo-discharge", "--dilatancy-angle", "0"): "a flow at the critical state, no volume change",
    ("grain-incline", "--seed", "0"): "a random seed",
    ("silo-filling", "--settle", "0"): "the paper's run length (the default)",
    ("silo-filling", "--jitter", "0"): "release positions on the axis",
}


def numeric_flags(parser):
    """(flag, dest) of every option that takes one value through a type (the numbers; not choices)."""
    return [(a.option_strings[-1], a.dest) for a in parser._actions
            if a.option_strings and a.nargs is None and a.type is not None and a.choices is None]


@pytest.mark.parametrize("name", list(CASES))
def test_every_numeric_flag_refuses_zero_negative_nan_inf_when_parsed(name, capsys):
    """Verify each numeric flag of the case takes a checking type (never bare int/float), refuses
    each of VALUES in one line naming the flag and the rule (exit 2), and parses an ALLOWED value
    as given."""
    parser = make_case_parser(case_module(name))
    flags = numeric_flags(parser)
    assert {"--end-time", "--frames", "--cfl", "--dt"} <= {f for f, _ in flags}
    for action in parser._actions:
        assert action.type not in (int, float), f"{name} {action.option_strings}: a bare {action.type.__name__}"
    for flag, dest in flags:
        for value in VALUES:
            if (name, flag, value) in ALLOWED or ("*", flag, value) in ALLOWED:
                assert getattr(parser.parse_args([flag, value]), dest) == float(value), (flag, value)
                continue
            with pytest.raises(SystemExit) as stop:
                parser.parse_args([flag, value])
            err = capsys.readouterr().err
            assert stop.value.code == 2, (flag, value)
            lines = err.strip().splitlines()
            assert len(lines) == 1 and flag in lines[0] and f"{value} is invalid" in lines[0], err


def test_allowed_list_names_real_flags():
    """Verify every ALLOWED entry names a case and a numeric flag that exist (no stale entry that
    would let a value through unnoticed)."""
    for case, flag, value in ALLOWED:
        names = list(CASES) if case == "*" else [case]
        for n in names:
            assert flag in {f for f, _ in numeric_flags(make_case_parser(case_module(n)))}, (case, flag)
        assert value in VALUES
