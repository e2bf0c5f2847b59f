"""The benchmarks behind ``viscore bench``: figures printed, never asserted.

They live beside the library, not in it, and call its public names (as
scikit-image's ``benchmarks/``): they need the whole chain (core, metrics and
the generators), and only the command line sits above all three.
"""
