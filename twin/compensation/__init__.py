"""Compensation: the paper's compensation benchmark on data whose truth is known, and its report."""
