"""Responses from normal modes: sensor and load matrices, modal FRFs with damping and
residual flexibility, and modal state-space models."""
