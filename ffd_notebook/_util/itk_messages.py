"""The one formatter of ITK and SimpleITK error messages, for every reader that calls them.

An ITK exception carries the C++ source file and line it came from, the object's class and
address (``ITK ERROR: NiftiImageIO(0x5624...)``) and, for MetaImage, a ``Reason:`` from the C
library that is usually stale (``No such file or directory`` for data that ends early). What a
user can act on is the description; the readers add the file's name themselves.
"""

from __future__ import annotations

import re

__all__ = ["itk_message"]

_ADDRESS = re.compile(r"\s*\(0x[0-9a-fA-F]+\)")
_PREFIXES = re.compile(r"^(?:ITK ERROR:\s*|sitk::ERROR:\s*|Description:\s*|ERROR:\s*)+")
_LONGEST = 300


def itk_message(exc: BaseException) -> str:
    """What an ITK or SimpleITK exception says, without source locations, object addresses or prefixes.

    Parameters
    ----------
    exc : BaseException
        A ``RuntimeError`` raised by SimpleITK (or ITK's Python wrapping).

    Returns
    -------
    str
        One line: the exception's description (at most 300 characters).

    Examples
    --------
    >>> itk_message(RuntimeError(
    ...     "Exception thrown in SimpleITK ImageFileReader_Execute: /src/itkPNGImageIO.cxx:360:\\n"
    ...     "ITK ERROR: PNGImageIO(0x55bbed46f6e0): PNG critical error in y.png"))
    'PNGImageIO: PNG critical error in y.png'
    >>> itk_message(RuntimeError("Exception thrown in SimpleITK ImageFileReader_Execute: /src/a.cxx:99:\\n"
    ...                          "sitk::ERROR: Unable to determine ImageIO reader for \\"x.nii\\""))
    'Unable to determine ImageIO reader for "x.nii"'
    >>> itk_message(RuntimeError(""))
    'unknown error'
    """
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    described = [line for line in lines if line.startswith("Description:")]
    errors = [line for line in lines if "ERROR:" in line]
    if described:
        chosen = described[-1]
    elif errors:
        chosen = errors[0][max(errors[0].find("ITK ERROR:"), errors[0].find("sitk::ERROR:"), 0) :]
    else:
        chosen = next((line for line in reversed(lines) if not line.startswith("Exception thrown in")),
                      lines[-1] if lines else "")  # fmt: skip
    chosen = _PREFIXES.sub("", _ADDRESS.sub("", chosen)).strip()
    if chosen.endswith(":") or not chosen:
        chosen = chosen.rstrip(":") or "unknown error"
    return chosen[:_LONGEST]
