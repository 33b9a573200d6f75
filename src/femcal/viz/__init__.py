"""Pictures: FRF overlays and stabilisation diagrams (matplotlib), renderings of meshes and
modes (pyvista, off-screen), the calibration report's pictures. Every module imports its
plotting library when first drawing, so importing femcal never loads VTK."""
