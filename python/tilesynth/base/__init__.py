"""Foundations every stage uses: the typed wrappers of the Rust kernels, input conversion, memory budgets,
signals and progress.
"""
