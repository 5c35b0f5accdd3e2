"""visnav margins: the delay-identification options refuse bad values in one line (exit code 2)."""

import pytest

from tests.cli.test_cli import _invoke, _one_line_error


@pytest.mark.parametrize("args", [["--min-delay-confidence", "1.5"], ["--min-delay-confidence", "-0.1"],
                                  ["--ident-seeds", "0"]])
def test_bad_delay_identification_options_are_one_line(tmp_path, args):
    _one_line_error(_invoke("margins", "palace-sweep", *args, "--out", tmp_path / "m"), args[0])
    assert not (tmp_path / "m").exists()  # refused before the output folder was made
