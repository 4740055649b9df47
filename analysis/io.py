"""Readers of the common format (``docs/formats.md``) into :mod:`analysis.frame` objects.

The particle reader is hand-written rather than MDAnalysis' ``LAMMPSDUMP`` reader
because MDAnalysis stores positions in float32 and drops the box origin, and contact
geometry (overlaps of 1e-4 diameters in boxes of tens of diameters) needs both.
Every reader reports a truncated or corrupt file as :class:`FormatError` naming the
file and line.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from analysis.frame import Contacts, Frame

THERMO_COLUMNS = ("step", "time", "phi", "pressure", "ke", "pe", "n_contacts")
CONTACT_COLUMNS = ("i", "j", "cx", "cy", "cz", "nx", "ny", "nz", "overlap", "fx", "fy", "fz")


class FormatError(ValueError):
    """A file does not follow the common format; the message names file and line."""


def _last_block_text(path: Path, chunk: int = 1 << 20) -> str:
    """The text of a dump from its last ``ITEM: TIMESTEP`` line on, read backwards from
    the end in chunks (a long run's dump need not be read whole for its final frame)."""
    marker = b"ITEM: TIMESTEP"
    try:
        fh = open(path, "rb")
    except FileNotFoundError:
        raise FormatError(f"{path}: no such file") from None
    with fh:
        pos = fh.seek(0, 2)
        buf = b""
        while pos > 0:
            size = min(chunk, pos)
            pos -= size
            fh.seek(pos)
            buf = fh.read(size) + buf
            k = buf.rfind(marker)
            while k > 0 and buf[k - 1:k] != b"\n":  # the marker must open a line
                k = buf.rfind(marker, 0, k)
            if k == 0 and pos > 0:
                continue  # the line may start in the previous chunk
            if k >= 0:
                return buf[k:].decode()
    raise FormatError(f"{path}: no 'ITEM: TIMESTEP' line: not a dump")


def _blocks(path: Path, count_item: str, lines: list[str] | None = None):
    """Yield ``(step, bounds (3, 2), periodic (3,), columns, table, first line)``; from
    ``lines`` when given (line numbers then count from their first)."""
    path = Path(path)
    try:
        lines = path.read_text().splitlines() if lines is None else lines
    except FileNotFoundError:
        raise FormatError(f"{path}: no such file") from None
    k = 0
    nlines = len(lines)
    while k < nlines:
        line = lines[k]
        if not line.strip():
            k += 1
            continue
        if not line.startswith("ITEM: TIMESTEP"):
            raise FormatError(f"{path}:{k + 1}: expected 'ITEM: TIMESTEP', got {line[:60]!r}")
        try:
            step = int(lines[k + 1])
            if not lines[k + 2].startswith(count_item):
                raise FormatError(f"{path}:{k + 3}: expected '{count_item}'")
            n = int(lines[k + 3])
            bounds_head = lines[k + 4]
            if not bounds_head.startswith("ITEM: BOX BOUNDS"):
                raise FormatError(f"{path}:{k + 5}: expected 'ITEM: BOX BOUNDS'")
            flags = bounds_head.split()[3:6]
            bounds = np.array([[float(v) for v in lines[k + 5 + a].split()[:2]] for a in range(3)])
            head = lines[k + 8]
        except (IndexError, ValueError) as exc:
            if isinstance(exc, FormatError):
                raise
            raise FormatError(f"{path}:{min(k + 9, nlines)}: truncated or corrupt frame header "
                              f"({exc})") from None
        if not head.startswith("ITEM: ATOMS") and not head.startswith("ITEM: ENTRIES"):
            raise FormatError(f"{path}:{k + 9}: expected 'ITEM: ATOMS' or 'ITEM: ENTRIES'")
        cols = head.split()[2:]
        first = k + 10
        body = lines[k + 9:k + 9 + n]
        if len(body) < n:
            raise FormatError(f"{path}:{nlines}: truncated: frame at step {step} announces {n} "
                              f"rows, only {len(body)} present")
        if n:
            tokens = " ".join(body).split()
            if len(tokens) != n * len(cols):
                for r, row in enumerate(body):
                    if len(row.split()) != len(cols):
                        raise FormatError(f"{path}:{first + r}: expected {len(cols)} columns, "
                                          f"got {len(row.split())}")
            try:
                table = np.array(tokens, dtype=np.float64).reshape(n, len(cols))
            except ValueError:
                for r, row in enumerate(body):
                    try:
                        [float(v) for v in row.split()]
                    except ValueError:
                        raise FormatError(f"{path}:{first + r}: not a number in {row[:80]!r}") from None
                raise
        else:
            table = np.zeros((0, len(cols)))
        periodic = np.array([f == "pp" for f in flags] if flags else [True] * 3)
        yield step, bounds, periodic, cols, table, first
        k += 9 + n


def read_particle_frames(path, last_only: bool = False) -> list[Frame]:
    """All frames of a particle dump (``id type x y z radius [ux uy uz length]``), or
    with ``last_only`` its final frame alone (read from the end of the file)."""
    frames = []
    lines = _last_block_text(Path(path)).splitlines() if last_only else None
    for step, bounds, periodic, cols, table, first in _blocks(path, "ITEM: NUMBER OF ATOMS",
                                                               lines):
        col = {c: k for k, c in enumerate(cols)}
        for need in ("id", "x", "y", "z", "radius"):
            if need not in col:
                raise FormatError(f"{path}:{first - 1}: particle dump lacks column '{need}'")
        order = np.argsort(table[:, col["id"]], kind="stable")
        t = table[order]
        n = len(t)
        axis = np.tile([0.0, 0.0, 1.0], (n, 1))
        length = np.zeros(n)
        if all(c in col for c in ("ux", "uy", "uz", "length")):
            axis = t[:, [col["ux"], col["uy"], col["uz"]]]
            length = t[:, col["length"]]
        frames.append(Frame(
            step=step, ids=t[:, col["id"]].astype(np.int64),
            types=t[:, col["type"]].astype(np.int64) if "type" in col else np.ones(n, np.int64),
            x=t[:, [col["x"], col["y"], col["z"]]].copy(), radius=t[:, col["radius"]].copy(),
            axis=axis, length=length, box_lo=bounds[:, 0].copy(),
            box=bounds[:, 1] - bounds[:, 0], periodic=periodic,
            # a box without z extent is a 2-D packing (pysim writes 2-D runs so)
            dimension=2 if bounds[2, 1] == bounds[2, 0] else None))
    return frames


def read_contact_frames(path) -> list[Contacts]:
    """All frames of a contact table (columns :data:`CONTACT_COLUMNS`)."""
    out = []
    for step, _b, _p, cols, t, first in _blocks(path, "ITEM: NUMBER OF ENTRIES"):
        if tuple(cols) != CONTACT_COLUMNS:
            raise FormatError(f"{path}:{first - 1}: contact columns {cols} differ from the "
                              f"common format {list(CONTACT_COLUMNS)}")
        out.append(Contacts(step=step, i=t[:, 0].astype(np.int64), j=t[:, 1].astype(np.int64),
                            point=t[:, 2:5].copy(), normal=t[:, 5:8].copy(),
                            overlap=t[:, 8].copy(), force=t[:, 9:12].copy()))
    return out


def read_thermo(path) -> pd.DataFrame:
    """The thermo table as a DataFrame with columns :data:`THERMO_COLUMNS`."""
    path = Path(path)
    try:
        with open(path) as fh:
            header = fh.readline()
    except FileNotFoundError:
        raise FormatError(f"{path}: no such file") from None
    names = header.lstrip("#").split()
    if tuple(names) != THERMO_COLUMNS:
        raise FormatError(f"{path}:1: thermo header {names} differs from {list(THERMO_COLUMNS)}")
    df = pd.read_csv(path, sep=r"\s+", comment="#", header=None, names=list(THERMO_COLUMNS),
                     na_values=["nan", "-nan"])
    # phi and pressure are nan in containers (no box packing fraction), pe where an engine
    # does not report it; a truncated row lacks its last columns
    bad = df[["step", "time", "ke", "n_contacts"]].isna().any(axis=1)
    if bad.any():
        raise FormatError(f"{path}:{int(np.flatnonzero(bad)[0]) + 2}: missing or non-numeric "
                          "value (truncated row?)")
    # a title line repeated by restarted runs is dropped by comment='#'
    return df.drop_duplicates(subset="step", keep="last").reset_index(drop=True)


#: columns of ``blocks.dat``, the block table of pysim's hard-sphere runs (docs/formats.md)
BLOCK_COLUMNS = ["step", "time", "phi", "rate", "reduced_pressure", "temperature", "stage"]


def read_blocks(path) -> pd.DataFrame:
    """``blocks.dat`` of a hard-sphere run: a row per block of collisions
    (:data:`BLOCK_COLUMNS`; ``stage`` ``ls``, ``fb`` or ``mls``)."""
    path = Path(path)
    if not path.is_file():
        raise FormatError(f"{path}: no such file (a hard-sphere run writes blocks.dat)")
    return pd.read_csv(path, sep=r"\s+", comment="#", header=None, names=BLOCK_COLUMNS)


class RunData:
    """The three common-format files of one run directory, read lazily."""

    def __init__(self, run_dir):
        self.dir = Path(run_dir)

    @property
    def thermo(self) -> pd.DataFrame:
        return read_thermo(self.dir / "thermo.dat")

    def frames(self) -> list[tuple[Frame, Contacts]]:
        """Particle frames paired with the contact table of the same step."""
        parts = read_particle_frames(self.dir / "particles.dump")
        conts = {c.step: c for c in read_contact_frames(self.dir / "contacts.dump")}
        out = []
        for f in parts:
            if f.step not in conts:
                raise FormatError(f"{self.dir / 'contacts.dump'}: no contact frame for step "
                                  f"{f.step} of particles.dump")
            out.append((f, conts[f.step]))
        return out
