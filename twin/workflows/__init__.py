"""Workflows: each command's job as one function taking one validated options object.

``twin compare`` is :func:`twin.workflows.compare.run_compare` on a
:class:`~twin.workflows.compare.CompareOptions`; the CLI only maps its options onto that object,
and :mod:`twin.reporting` only renders what the workflow returns.
"""
