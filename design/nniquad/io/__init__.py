"""The one input/output layer of the project: bounded reads, checked output paths, atomic writes.

Reading (:func:`read_text_file`, :func:`parse_data`, :func:`load_data_file`)
    Every input file (a vehicle, a certificate) is read by the same function:
    only a regular file is opened (a FIFO, a device such as ``/dev/zero`` or a
    folder is refused without blocking), at most
    :data:`nniquad.config.INPUT_MAX_BYTES` are read, the bytes must be UTF-8
    text (binary and UTF-16 files are refused by name), and the JSON or TOML
    parse refuses duplicate keys, integers longer than
    :data:`nniquad.config.INPUT_MAX_INT_DIGITS` digits or beyond the float
    range, and nesting deeper than :data:`nniquad.config.INPUT_MAX_DEPTH`.
    Every problem is one line of the caller's error class
    (``VehicleError``, ``CertificateError``, ...).

Writing (:func:`check_output_path`, :func:`check_output_paths`, :func:`atomic_write_with`, :func:`output_transaction`)
    Output paths are checked before any work starts: not a folder, no file
    used as a folder on the way, not a device, and a probe file can be
    created in the nearest existing folder (root ignores permission bits, so
    only a real probe tells).  Every file is written to a temporary file in
    its folder and renamed; inside :func:`output_transaction` the renames wait
    until the whole transaction has succeeded, so a command with several
    outputs writes all of them or none.  A failed write leaves nothing behind,
    not even the folders it created.
"""

from __future__ import annotations

from nniquad.io.reading import format_bytes, load_data_file, parse_data, read_text_file
from nniquad.io.writing import (
    atomic_write_json,
    atomic_write_text,
    atomic_write_with,
    check_output_folder,
    check_output_path,
    check_output_paths,
    output_transaction,
)

__all__ = [
    "atomic_write_text",
    "atomic_write_json",
    "atomic_write_with",
    "output_transaction",
    "check_output_path",
    "check_output_paths",
    "check_output_folder",
    "read_text_file",
    "parse_data",
    "load_data_file",
    "format_bytes",
]
