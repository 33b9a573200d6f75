"""Bundled models: generators of NASTRAN decks and their data files."""
