"""The application layer (top floor).

Assembly of a spacecraft file into objects, the design, the report, the
built-in Monte Carlo scenarios and the command line. The only part of
:mod:`attitude` that imports :mod:`controllers` and :mod:`estimation`.
"""
