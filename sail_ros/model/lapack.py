"""The raw LAPACK routines the model and the integration call without scipy's wrappers.

On matrices assembled from checked lengths scipy's checks (finite values, shapes) cost
more than the solve at a few dozen coordinates; these are the same calls its wrappers
make (`cho_factor`/`cho_solve`: potrf/potrs, `eigh(K, M)`: sygvd, `lu_solve`: getrs,
`solve` of complex blocks: gesv). One set, fetched once.
"""

import scipy.linalg

potrf, potrs, sygvd, getrs = scipy.linalg.lapack.get_lapack_funcs(
    ("potrf", "potrs", "sygvd", "getrs"), dtype=float
)
gesv_complex = scipy.linalg.lapack.get_lapack_funcs("gesv", dtype=complex)
