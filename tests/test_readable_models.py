"""Issue #31: no model code keeps a hand-unrolled copy of a numpy expression for bit-identity. The patterns the
review named (``z = wr*0.0`` to make zeros of a shape, ``np.tan(x[4:5]).item()`` to stay on floats, ``(f0 + 0.0)``
to copy a float) are not in src/ outside the kernel modules (``*/kernels.py``), where speed lives apart from the
readable models and is tested against them."""

from __future__ import annotations

import re
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src" / "visnav"
PATTERNS = {
    "zeros by multiplying by 0.0": re.compile(r"\w\s*\*\s*0\.0\b(?!\d)"),
    "a float copied by adding 0.0": re.compile(r"\+\s*0\.0\s*\)"),
    "a one-element slice through numpy to a float": re.compile(r"np\.\w+\(\w+\[\d+:\d+\]\)\.item\(\)"),
}


def unrolled(text: str) -> list[str]:
    return [f"{name}: {line.strip()}" for line in text.splitlines() for name, rx in PATTERNS.items()
            if rx.search(line.split("#", 1)[0])]


def test_the_patterns_are_seen():
    assert len(unrolled("z = wr*0.0\nf = (f0 + 0.0)\nt = np.tan(x[4:5]).item()\nok = a * 0.05  # x*0.0")) == 3


def test_no_unrolled_numpy_in_the_models():
    found = [f"{p.relative_to(SRC)}: {hit}" for p in sorted(SRC.rglob("*.py")) if p.name != "kernels.py"
             for hit in unrolled(p.read_text())]
    assert not found, "\n".join(found)
