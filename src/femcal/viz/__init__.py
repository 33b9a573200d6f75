"""Pictures: FRF overlays and stabilisation diagrams (matplotlib), renderings of meshes and
modes (pyvista, off-screen), animated GIFs of modes, the self-contained HTML page of modes,
the calibration report's pictures. Every module imports its plotting library when first
drawing, so importing femcal never loads VTK."""

import importlib

#: Public name -> the module that defines it, imported when first used (so that importing
#: one picture does not load the others).
_EXPORTS = {
    # still pictures of modes and meshes (pyvista, off-screen)
    "render_modes": "render", "render_mesh": "render",
    # modes oscillating over one period as GIFs
    "animate_modes": "animate",
    # the interactive page of modes: one HTML file, no server
    "write_webview": "webview", "read_webview": "webview", "browser_check": "webview",
}  # fmt: skip

__all__ = list(_EXPORTS)


def __getattr__(name: str) -> object:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'femcal.viz' has no attribute {name!r}")
    return getattr(importlib.import_module(f"femcal.viz.{module}"), name)
