"""What the machine can give: memory checks made before a large allocation, so that a request
too big for the machine is a clear error instead of minutes of swapping or a MemoryError."""

from __future__ import annotations

import os

from .errors import ResourceError


def available_memory_bytes() -> int | None:
    """Memory the machine can give now (Linux ``MemAvailable``), or None where unknown."""
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return None


def human_bytes(n: float) -> str:
    """``1.5 GiB`` style size."""
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if abs(n) < 1024 or unit == "PiB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1024
    return f"{n:.1f} PiB"  # pragma: no cover


def check_memory(n_bytes: float, what: str, *, fraction: float = 0.8) -> None:
    """Raise :class:`ResourceError` when ``n_bytes`` exceed ``fraction`` of the memory
    available now; ``what`` says what would need it (``"1000 modes of 86718 DOF"``)."""
    avail = available_memory_bytes()
    if avail is not None and n_bytes > fraction * avail:
        raise ResourceError(f"{what} would need {human_bytes(n_bytes)} of memory; "
                            f"{human_bytes(avail)} is available")  # fmt: skip
