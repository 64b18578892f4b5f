"""Rows of numbers in text mesh files (OFF, ASCII PLY), read at once: every row's values and how many
it has, for formats whose rows differ in length (polygons of any number of corners, colours or not)."""

import re

import numpy as np

_SPACE = np.frombuffer(b" \t\r\n\v\f", dtype=np.uint8)


def rows(text):
    """The non-blank lines of ``text`` (bytes).

    Returns
    -------
    list of bytes
    """
    return re.findall(rb"[^\n]*?\S[^\n]*", text)


def words_per_line(block, lines):
    """How many words (runs of non-space bytes) each of the ``lines`` lines of ``block`` (bytes) holds."""
    data = np.frombuffer(block, dtype=np.uint8)
    space = np.isin(data, _SPACE)
    begins = ~space & np.concatenate([[True], space[:-1]])
    return np.bincount(np.cumsum(data == ord("\n"))[begins], minlength=lines)


def numbers(lines):
    """The numbers of ``lines`` (a list of bytes), one row per line.

    Returns
    -------
    values : ndarray of float64
        Every number, row after row.
    counts : ndarray of int64
        How many numbers each row holds.

    Raises
    ------
    ValueError
        A word that is no number.
    """
    block = b"\n".join(lines)
    counts = words_per_line(block, len(lines))
    words = block.split()
    try:
        values = np.array(words, dtype=np.float64)
    except ValueError:
        bad = next(w for w in words if not re.fullmatch(rb"[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?|[-+]?(nan|inf)", w,
                                                          re.I))
        raise ValueError(f"{bad.decode('latin-1')!r} is not a number") from None
    return values, counts


def decimal_places(points):
    """Decimal places for text formats (trimesh writes fixed-point numbers) that keep 17
    significant digits of the largest coordinate, so a mesh a micron across keeps its shape."""
    largest = float(np.abs(points).max()) if len(points) else 0.0
    return int(np.clip(17 - np.floor(np.log10(largest)), 8, 330)) if largest > 0 else 8
