"""Private helpers shared by several of the package's subpackages (lazy imports, BLAS threads, renamed keywords)."""
