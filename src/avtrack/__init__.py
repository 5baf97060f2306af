"""avtrack: variational-Bayesian multi-person tracking from cameras, microphones, or both.

The method family is Y. Ban, *Audio-Visual Multiple-Speaker Tracking for Robot Perception*
(PhD thesis, 2019) — "the thesis" in docstrings, cited by equation number.
"""

from avtrack.errors import InputError

__version__ = "0.1.0"

__all__ = ["InputError", "__version__"]
