"""What composes the layers below into a study: configs, sweeps, studies, the report.

- ``config``: TOML configs of runs; ``sweep``: a task over a parameter grid on Dask, resumable;
- ``study`` (with ``studies/*.toml``): the paper's parametric studies; ``paper``: the report;
- ``costs``: the measured costs the README, docs and help quote.

May import: everything but :mod:`vesicle.cli`.
"""
