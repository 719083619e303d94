"""Every equation reference in the code names its paper, and docs/equations.md
indexes exactly the (paper, equation) pairs the code refers to.

A reference is ``eq. N``, ``eqs. N-M, K`` or ``equation N`` (any case, the
number optionally in parentheses) anywhere in a source file under
cpp/pfmpm, cpp/bindings or src/pfmpm (.h, .cpp, .py, .toml: comments,
docstrings, and the descriptions and messages the code gives its users). It
names its paper when one of KEYS (or an ALIASES name) stands right before
it, separated by at most a comma and spaces or a line break and the comment
marker that continues the comment: ``K&T eq. 14``, ``(H&H eqs. 17-19)``,
``Jiang et al. 2015, eq. 10``, ``Homel & Herbold 2017, eq. 22``. The key
applies to every number of its reference (``K&T eqs. 80, 82, 78``,
``K&T eqs. 22c-22e``: 22c, 22d and 22e). The keys are the section headings
of docs/equations.md, whose table rows list one equation each.
"""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SOURCES = ("cpp/pfmpm", "cpp/bindings", "src/pfmpm")
SUFFIXES = {".h", ".cpp", ".py", ".toml"}
INDEX = ROOT / "docs" / "equations.md"

#: The papers the code cites by equation number, by key (the headings of docs/equations.md).
KEYS = ("K&T", "H&H", "Jiang et al. 2015")
#: Names that stand for a key: the authors and year in full.
ALIASES = {"Kakouris & Triantafyllou 2019": "K&T", "Homel & Herbold 2017": "H&H"}

# Between the words of a reference: spaces, or one line break and the comment
# marker that continues the comment (///, ///<, //, #, #:, *).
GAP = r"(?:[ \t]+|[ \t]*\n[ \t]*(?:///<|///|//|#:|#|\*)?[ \t]*)"
NUMBER = r"\(?\d+[a-z]?\)?"
SPAN = rf"{NUMBER}(?:\s*[-/]\s*{NUMBER})?"
REFERENCE = re.compile(
    rf"\b(?:(?P<plural>eqs\.|equations)|eq\.|equation){GAP}?"
    rf"(?P<numbers>{SPAN}(?(plural)(?:(?:,{GAP}|{GAP}and{GAP}){SPAN})*))",
    re.IGNORECASE)
_KEY = "|".join(GAP.join(map(re.escape, name.split())) for name in (*KEYS, *ALIASES))
KEYED = re.compile(rf"(?:^|[^\w&])(?P<key>{_KEY}),?{GAP}$")


def _numbers(text):
    """The equation numbers of a reference's number list: ``"22c-22e, 8"`` is
    ``["22c", "22d", "22e", "8"]``."""
    found = []
    for span in re.split(rf",{GAP}|{GAP}and{GAP}", text):
        ends = [e.strip("() \t") for e in re.split(r"\s*[-/]\s*", span.strip())]
        if len(ends) == 2 and "-" in span:
            (a, sa), (b, sb) = (re.fullmatch(r"(\d+)([a-z]?)", e).groups() for e in ends)
            if sa and sb and a == b:
                found += [a + chr(c) for c in range(ord(sa), ord(sb) + 1)]
            else:
                found += [str(n) for n in range(int(a), int(b) + 1)]
        else:
            found += ends
    return found


def references():
    """(file, line, text, key or None, numbers) for every reference in the sources."""
    out = []
    for top in SOURCES:
        for path in sorted((ROOT / top).rglob("*")):
            if path.suffix not in SUFFIXES or not path.is_file():
                continue
            text = path.read_text(encoding="utf-8")
            for m in REFERENCE.finditer(text):
                line = text.count("\n", 0, m.start()) + 1
                named = KEYED.search(text, max(0, m.start() - 60), m.start())
                key = None if named is None else re.sub(GAP, " ", named.group("key"))
                shown = " ".join(m.group(0).split())
                if shown.count(")") > shown.count("("):
                    shown = shown[:-1]
                out.append((path.relative_to(ROOT).as_posix(), line, shown, ALIASES.get(key, key),
                            _numbers(m.group("numbers"))))
    return out


def index():
    """{key: {equation: the index's line}} from docs/equations.md: its ``## KEY: citation``
    sections and their table rows ``| N | ... |``."""
    entries, key = {}, None
    for line in INDEX.read_text(encoding="utf-8").splitlines():
        if heading := re.match(r"## (.+?):", line):
            key = heading.group(1)
            entries[key] = {}
        elif key and (row := re.match(r"\|\s*(\d+[a-z]?)\s*\|", line)):
            assert row.group(1) not in entries[key], f"docs/equations.md: {key} eq. {row.group(1)} twice"
            entries[key][row.group(1)] = line
    return entries


def test_every_equation_reference_names_its_paper():
    refs = references()
    assert len(refs) > 300
    unnamed = [f"{file}:{line}: {text}" for file, line, text, key, _ in refs if key is None]
    assert not unnamed, (f"{len(unnamed)} equation references name no paper (one of {', '.join(KEYS)}"
                         " right before eq.):\n" + "\n".join(unnamed))


def test_the_index_lists_exactly_the_referenced_equations():
    entries = index()
    assert sorted(entries) == sorted(KEYS)
    referenced = {(key, n) for _, _, _, key, numbers in references() if key for n in numbers}
    listed = {(key, n) for key, rows in entries.items() for n in rows}
    for key, rows in entries.items():
        numbers = [int(re.match(r"\d+", n).group()) for n in rows]
        assert numbers == sorted(numbers), f"docs/equations.md: {key} out of order"
    missing = sorted(referenced - listed)
    unused = sorted(listed - referenced)
    assert not missing, f"referenced in the code but not in docs/equations.md: {missing}"
    assert not unused, f"in docs/equations.md but referenced nowhere in the code: {unused}"
