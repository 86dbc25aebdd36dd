"""Figures (matplotlib, Agg): of runs, steady states, branches and phase diagrams.

- ``runs``, ``steady``, ``branch``, ``phase``: one module per kind of file drawn.

May import: everything below the workflows; never :mod:`vesicle.workflows` or the CLI.
"""
