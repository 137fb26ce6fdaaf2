"""The chaos suite, the readers (issue 23): seeded mutations of a valid file of every reader (byte flips,
truncation, blocks of zeros or duplicated, stray quotes, CR-LF and CR-only line ends, lines deleted, doubled or
broken), each read: a message naming the file, or the right rows; never a traceback, never rows lost without a word
(``tests/chaos_files.py`` says how each outcome is told). ``benchmarks/chaos.py`` runs the same with many more cases.

A (reader, mutation) pair that fails today in a reader another change is fixing is a strict expected failure,
with the reason and a replayable case in :data:`KNOWN`: it fails once fixed, and then its marker goes.
"""

from __future__ import annotations

import pytest

import chaos_files as chaos

CASES = 8  #: mutated files per (reader, mutation) pair

#: (reader, mutation) -> why it fails today (each reproducible: ``chaos.mutate(seed, mutation, rng(seed))``); none
#: since a stray non-UTF-8 byte is shown in the message and ezc3d reads in a child process (its abort a message)
KNOWN: dict[tuple[str, str], str] = {}


@pytest.fixture(scope="module")
def seeds(tmp_path_factory):
    return {s.name: s for s in chaos.make_seeds(tmp_path_factory.mktemp("seeds"))}


def _pairs():
    text = ("csv", "csv-comments", "motive", "vicon", "aem", "ur-rtde", "tum", "kitti", "euroc", "xsens", "xsens-dot")
    names = ("npz", "parquet", "qtm-mat", "c3d", "rosbag1", "rosbag2", *text)
    for name in names:
        kinds = chaos.TEXT_MUTATIONS if name in text else chaos.BINARY_MUTATIONS
        for kind in kinds:
            why = KNOWN.get((name, kind))
            marks = [pytest.mark.xfail(strict=True, reason=why)] if why else []
            yield pytest.param(name, kind, marks=marks, id=f"{name}-{kind}")


@pytest.mark.parametrize(("reader", "mutation"), list(_pairs()))
def test_a_damaged_file_gives_a_message_or_its_rows(seeds, tmp_path, reader, mutation):
    cases = chaos.run_cases(seeds[reader], tmp_path, CASES, base_seed=0, mutations=(mutation,))
    assert not chaos.failures(cases), chaos.describe(cases)
    assert sum(chaos.counts(cases).values()) == CASES


def test_the_oracle_counts_rows_independently():
    # a text file's rows: its non-blank lines after the header, whatever the line ends
    text = b"t,q\n\n0,1\r\n1,2\r2,3\n  \n"
    assert chaos.text_rows(text, 1) == 3
    assert chaos.header_end(b"a\n\nb\nc\n", 2) == 5
    # a read that loses a row without a word is caught, one that says so is not
    short = type("Log", (), {"__len__": lambda self: 9, "notes": ()})()
    said = type("Log", (), {"__len__": lambda self: 9, "notes": ("dropped 1 duplicated sample(s) (same time",)})()
    assert chaos.classify_read(None, "f.csv", 10, lambda: short)[0] == "silent"
    assert chaos.classify_read(None, "f.csv", 10, lambda: said)[0] == "rows"
    assert chaos.classify_read(None, "f.csv", 10, lambda: (_ for _ in ()).throw(ValueError("f.csv: bad")))[0] == (
        "message"
    )
    assert chaos.classify_read(None, "f.csv", 10, lambda: (_ for _ in ()).throw(ValueError("bad")))[0] == "unnamed"
    assert chaos.classify_read(None, "f.csv", 10, lambda: (_ for _ in ()).throw(KeyError("x")))[0] == "traceback"
