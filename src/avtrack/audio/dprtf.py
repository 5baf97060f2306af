"""Online multichannel direct-path relative transfer function (DP-RTF) estimation.

Thesis §5.2 (eqs. 5.1–5.11, Algorithm 2), after Li et al. [78, 81]. For each frequency ``f``
the convolutive transfer functions (CTFs) ``a^i_f`` of length ``Q`` from one speaker to the
``I`` microphones satisfy, for every microphone pair ``(i, j)``, the cross-relation

.. math::

    \\mathbf{x}^{i\\top}_{t,f} \\mathbf{a}^j_f = \\mathbf{x}^{j\\top}_{t,f} \\mathbf{a}^i_f
    \\qquad (5.2)

with ``x^i_{t,f} = (x^i_{t,f}, ..., x^i_{t-Q+1,f})``. Stacking the ``I Q`` CTF coefficients,
each pair gives one linear equation ``x^{ij T}_{t,f} a_f = 0`` (5.3, 5.4); fixing the first
coefficient of a reference channel to 1 turns it into ``x~^{m T} a~ = y^m`` (5.5, 5.6), solved
online by recursive least squares over all ``M = I (I - 1) / 2`` pairs with forgetting factor
``lambda = (P - 1) / (P + 1)``, ``P = rho (I Q - 1) / M`` (5.7–5.9). The DP-RTFs are the
first CTF coefficients of the channels over that of the reference channel.

Noise (§5.2.2): instead of the STFT vectors, the equations use the recursively averaged
cross-PSDs ``phi^i_{t,f}`` between ``x^i_{t,f}`` and the current reference coefficient
``x^1_{t,f}`` (eq. 5.10) after inter-frame spectral subtraction (:mod:`avtrack.audio.noise`);
only speech bins update the RLS, noise bins are skipped.

Memory across noise frames. The RLS of a bin is carried over the noise frames it skips (a
speech frame after noise frames starts from the latest speech frame's estimate, §5.2.2). By
default (``forget_over_noise=True``) the forgetting factor keeps counting frames of *time*
while the bin is skipped: after ``g`` frames (``g - 1`` of them noise), the old covariance is
weighted ``lambda^g`` instead of ``lambda`` -- noise frames add no equation, but they do age
the ones in memory, so that the estimate keeps the short memory of ``P`` frames the forgetting
factor is chosen for (the CTF is assumed constant over "a few consecutive frames"). A bin's
features are given only while its memory holds at least as many equations as after
``min_frames`` consecutive speech frames from scratch: with ``n_t = lambda^g n_{t'} + 1``
(``n = 1`` at a first speech frame), a feature needs ``n_t >= sum_{k < min_frames} lambda^k``
(with ``g = 1`` always this is exactly "``min_frames`` speech frames seen"). Without this, the
first speech frames of a bin that was silent for a while -- typically a new talker after a
turn change -- are dominated by the previous talker's equations and give features pointing at
the previous talker (or, once aged, at an under-determined mixture). When the memory has faded
below ``1e-5`` of a new frame (``lambda^g < 1e-5``: 30 frames for ``lambda = 25/37``), the bin
restarts as at its first speech frame (``R_0 = delta I``); this keeps Algorithm 2's
``P = R^{-1}``, divided by ``lambda^g``, within ``1e5`` of its value (the two solvers then agree
to ~1e-6 across pauses).
``forget_over_noise=False`` freezes the memory over noise frames (the literal reading of
§5.2.2 and the authors' reference code).

Consistency test (eq. 5.11): the DP-RTFs are estimated with channel 1 and with channel 2 as
reference; the two estimates of ``a^i_0 / a^1_0`` are kept when the cosine similarity of
``(1, c~^i)`` and ``(1, c̄^i / c̄^1)`` is at least 0.75, then averaged (``c``) and normalised,
``ĉ = c / sqrt(1 + |c|^2)`` (the second entry of the unit vector along ``(1, c)``), so that
``|ĉ| < 1`` [78].

Implementation
--------------
Two solvers give the same estimates (checked in the tests to ~1e-8):

- ``solver="rls"`` is Algorithm 2 as printed: per reference channel, a reduced RLS state
  ``(a~, P)`` updated by one Sherman–Morrison step per microphone pair, vectorised over the
  frequencies (the pair loop inside).
- ``solver="cholesky"`` (default, faster) uses that Algorithm 2 after the ``M`` pair updates of
  frame ``t`` is exactly eq. 5.9, ``a~_t = R_t^{-1} r_t``, with the full ``IQ x IQ``
  covariance of the homogeneous equations
  ``R_t = lambda R_{t-1} + sum_m x^{m*}_t x^{m T}_t``, ``R_0 = delta I``. Minimising
  ``a^H R_t a`` with one coefficient fixed to 1 gives ``a ∝ R_t^{-1} e_ref``, so both
  references come from the ``I x I`` block of ``R_t^{-1}`` on the first CTF coefficients,
  which is the inverse of the Schur complement read off one Cholesky factorisation. The sum
  over pairs has a closed form in the per-channel PSD vectors ``v^k = phi-hat^k``:
  ``R[(k, q), (l, p)] += delta_kl sum_j conj(v^j_q) v^j_p - conj(v^l_q) v^k_p``.

The Cholesky solver runs as one compiled loop over the speech bins (Numba,
``avtrack.audio._dprtf_kernel``: memory weight, update, factorisation, the two small solves
and the consistency test while the bin's matrix is in cache). The NumPy form remains
(``AVTRACK_NO_JIT=1``, or Numba missing); the two agree to ~1e-9 and only the bins that give a
feature are factorised.

Regularisation: the thesis initialises ``P = I`` (``R_0 = I``); to make the estimates
independent of the signal's scale we use ``R_0 = delta I`` with
``delta = regularization * trace(U_1)`` at a bin's first speech frame (``U_1`` that
frame's equations). A relative diagonal loading of ``1e-12 trace(R) / (IQ)`` guards the
Cholesky factorisation.

Shapes: STFT frame ``(n_channels, n_freqs)``; features ``(n_channels - 1, n_freqs)`` per frame
(``(n_channels - 1, n_freqs, n_frames)`` for a batch), entry ``i - 1`` for channel ``i``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from avtrack.audio import _dprtf_kernel
from avtrack.audio.noise import NoiseConfig, NoiseTracker, recursive_average

SOLVERS = ("cholesky", "rls")
_LOADING = 1e-12
#: a bin whose memory weighs less than this (``lambda^gap``) restarts from ``R_0 = delta I``
_FADED = 1e-5


def forgetting_factor(n_mics: int, ctf_length: int, rho: float = 1.0) -> float:
    """RLS forgetting factor ``lambda = (P - 1) / (P + 1)``, ``P = rho (IQ - 1) / (I(I-1)/2)``.

    ``P`` is the number of frames that provide ``rho`` times as many equations as unknowns
    (thesis §5.2.2). ``P`` is clipped to at least 1 (``lambda >= 0``, memory of one frame),
    which matters for ``Q = 1`` (narrow-band / PRP features).
    """
    if n_mics < 2:
        raise ValueError(f"forgetting_factor: n_mics must be >= 2, got {n_mics}")
    if ctf_length < 1:
        raise ValueError(f"forgetting_factor: ctf_length must be >= 1, got {ctf_length}")
    if not rho > 0:
        raise ValueError(f"forgetting_factor: rho must be > 0, got {rho}")
    n_pairs = n_mics * (n_mics - 1) / 2
    p = max(1.0, rho * (n_mics * ctf_length - 1) / n_pairs)
    return (p - 1.0) / (p + 1.0)


@dataclass(frozen=True)
class DPRTFConfig:
    """Parameters of :class:`DPRTFEstimator` (thesis §5.2 and §5.5.1).

    Attributes
    ----------
    ctf_length : int
        ``Q``, CTF length in frames (8 in the thesis).
    rho : float
        Equations-to-unknowns ratio that sets the forgetting factor (1 in the thesis).
    forgetting : float or None
        Explicit ``lambda`` in [0, 1]; None: :func:`forgetting_factor`.
    psd_smoothing : float
        ``beta`` of the recursive PSD averaging (eq. 5.10), in [0, 1).
    consistency_threshold : float
        Minimum similarity ``d`` of eq. 5.11 (0.75 in the thesis).
    regularization : float
        Relative initial regularisation ``delta`` (see the module docstring), > 0.
    solver : {"cholesky", "rls"}
        Normal-equation form (fast) or Algorithm 2 as printed; same results.
    phase_only : bool
        Keep only the phase of the averaged DP-RTF: ``ĉ = (c / |c|) / sqrt(2)`` (pair-wise
        relative phase features, used with ``ctf_length=1`` by PRP-REM).
    freq_range_hz : (float, float) or None
        Only bins with ``lo <= f <= hi`` are processed (others never give features).
    noise : NoiseConfig or None
        Minimum statistics and speech/noise classification; None: no noise reduction, every
        bin is a speech bin (clean signals, tests).
    forget_over_noise : bool
        The RLS memory of a bin keeps ageing (by ``lambda`` per frame) over the noise frames it
        skips, and its features wait until the memory again holds enough equations (see the
        module docstring). False: the memory is frozen over noise frames.
    """

    ctf_length: int = 8
    rho: float = 1.0
    forgetting: float | None = None
    psd_smoothing: float = 0.7
    consistency_threshold: float = 0.75
    regularization: float = 1e-3
    solver: str = "cholesky"
    phase_only: bool = False
    freq_range_hz: tuple[float, float] | None = None
    noise: NoiseConfig | None = field(default_factory=NoiseConfig)
    forget_over_noise: bool = True

    def __post_init__(self) -> None:
        q = self.ctf_length
        if isinstance(q, bool) or not isinstance(q, int | np.integer) or q < 1:
            raise ValueError(f"DPRTFConfig: ctf_length must be a positive integer, got {q!r}")
        if not (isinstance(self.rho, int | float) and self.rho > 0):
            raise ValueError(f"DPRTFConfig: rho must be > 0, got {self.rho!r}")
        lam = self.forgetting
        if lam is not None and not (isinstance(lam, int | float) and 0.0 <= lam <= 1.0):
            raise ValueError(f"DPRTFConfig: forgetting must be in [0, 1] or None, got {lam!r}")
        b = self.psd_smoothing
        if not (isinstance(b, int | float) and 0.0 <= b < 1.0):
            raise ValueError(f"DPRTFConfig: psd_smoothing must be in [0, 1), got {b!r}")
        c = self.consistency_threshold
        if not (isinstance(c, int | float) and 0.0 <= c <= 1.0):
            raise ValueError(f"DPRTFConfig: consistency_threshold must be in [0, 1], got {c!r}")
        if not (isinstance(self.regularization, int | float) and self.regularization > 0):
            raise ValueError(
                f"DPRTFConfig: regularization must be > 0, got {self.regularization!r}"
            )
        if self.solver not in SOLVERS:
            raise ValueError(f"DPRTFConfig: solver must be one of {SOLVERS}, got {self.solver!r}")
        if self.freq_range_hz is not None:
            fr = tuple(self.freq_range_hz)
            if len(fr) != 2 or not fr[0] <= fr[1]:
                raise ValueError(
                    f"DPRTFConfig: freq_range_hz must be (lo, hi) with lo <= hi, got {fr!r}"
                )
            object.__setattr__(self, "freq_range_hz", (float(fr[0]), float(fr[1])))
        if self.noise is not None and not isinstance(self.noise, NoiseConfig):
            raise TypeError(
                f"DPRTFConfig: noise must be a NoiseConfig or None, got {self.noise!r}"
            )
        if not isinstance(self.forget_over_noise, bool):
            raise ValueError(
                f"DPRTFConfig: forget_over_noise must be a bool, got {self.forget_over_noise!r}"
            )


@dataclass(frozen=True)
class DPRTFFeatures:
    """DP-RTF features of a run of frames.

    Attributes
    ----------
    values : ndarray (n_channels - 1, n_freqs, n_frames), complex
        Normalised features ``ĉ^i_{t,f}`` for channels ``i = 2..I`` (0 where not valid).
    valid : ndarray (n_channels - 1, n_freqs, n_frames), bool
        Speech bin and consistency test passed (the set ``C_t`` of the thesis).
    speech : ndarray (n_freqs, n_frames), bool
        Speech bins (RLS updated).
    """

    values: np.ndarray
    valid: np.ndarray
    speech: np.ndarray

    def __post_init__(self) -> None:
        if self.values.shape != self.valid.shape or self.values.ndim != 3:
            raise ValueError(
                f"DPRTFFeatures: values and valid must have the same 3-D shape, got "
                f"{self.values.shape} and {self.valid.shape}"
            )
        if self.speech.shape != self.values.shape[1:]:
            raise ValueError(
                f"DPRTFFeatures: speech must have shape {self.values.shape[1:]}, got "
                f"{self.speech.shape}"
            )


def rls_pair_updates(
    a: np.ndarray, p: np.ndarray, x: np.ndarray, y: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Algorithm 2 of the thesis (one frame), vectorised over frequencies, in place.

    Parameters
    ----------
    a : ndarray (F, N), complex
        ``a~^0_{t,f}`` (the previous frame's estimate).
    p : ndarray (F, N, N), complex
        ``P^0_{t,f} = lambda^{-1} P^M_{t-1,f}`` (already divided by ``lambda``).
    x : ndarray (F, M, N), complex
        ``x~^m_{t,f}``, one row per microphone pair.
    y : ndarray (F, M), complex
        ``y^m_{t,f}``.

    Returns
    -------
    a, p : the updated arrays ``a~^M_{t,f}``, ``P^M_{t,f}`` (the inputs, modified).
    """
    for m in range(x.shape[1]):
        xm = x[:, m]  # (F, N)
        e = y[:, m] - np.einsum("fn,fn->f", xm, a)  # e = y - x~^T a~
        px = np.einsum("fnk,fk->fn", p, xm.conj())  # P x~*
        g = px / (1.0 + np.einsum("fn,fn->f", xm, px))[:, None]  # gain vector
        # P = P - g x~^T P ; x~^T P = (P^H x~*)^H = (P x~*)^H since P is Hermitian
        p -= g[:, :, None] * px.conj()[:, None, :]
        a += e[:, None] * g  # a~ = a~ + e g
    return a, p


def dprtf_features(
    c_ref1: np.ndarray, c_ref2: np.ndarray, threshold: float = 0.75, phase_only: bool = False
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Consistency test (eq. 5.11), averaging and normalisation of two DP-RTF estimates.

    Parameters
    ----------
    c_ref1 : ndarray, complex
        ``c~^i``: the DP-RTF ``a^i_0 / a^1_0`` estimated with channel 1 as reference.
    c_ref2 : ndarray, complex, same shape
        ``c̄^i / c̄^1``: the same DP-RTF from the estimate with channel 2 as reference.
    threshold : float
        Minimum similarity (0.75 in the thesis).
    phase_only : bool
        Return ``(c / |c|) / sqrt(2)`` instead of ``c / sqrt(1 + |c|^2)``.

    Returns
    -------
    values : ndarray, complex
        ``ĉ`` (0 where not valid).
    valid : ndarray, bool
        ``d >= threshold`` and finite.
    similarity : ndarray
        ``d`` of eq. 5.11, in [0, 1] (NaN where an estimate is not finite).
    """
    c1 = np.asarray(c_ref1)
    c2 = np.asarray(c_ref2)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        # d = |c_1^H c_2| / sqrt(c_1^H c_1 c_2^H c_2),  c_1 = (1, c~), c_2 = (1, c̄/c̄^1) (5.11)
        d = np.abs(1.0 + c1.conj() * c2) / np.sqrt(
            (1.0 + np.abs(c1) ** 2) * (1.0 + np.abs(c2) ** 2)
        )
        c = 0.5 * (c1 + c2)  # the two estimates averaged
        if phase_only:
            feat = c / (np.abs(c) * np.sqrt(2.0))
        else:
            feat = c / np.sqrt(1.0 + np.abs(c) ** 2)  # |ĉ| < 1 [78]
    valid = (d >= threshold) & np.isfinite(feat) & np.isfinite(d)
    return np.where(valid, feat, 0.0), valid, d


class DPRTFEstimator:
    """Online DP-RTF features, one STFT frame at a time (thesis §5.2, Algorithm 2).

    Parameters
    ----------
    n_channels : int
        ``I >= 3`` microphones (the consistency test needs a third channel besides the two
        references; with ``I = 2`` use ``consistency_threshold=0``).
    n_freqs : int
        Number of STFT bins.
    freqs_hz : ndarray (n_freqs,), optional
        Bin frequencies, needed only with ``config.freq_range_hz``.
    config : DPRTFConfig, optional

    Notes
    -----
    :meth:`step` returns ``(values (I-1, F), valid (I-1, F))`` for one frame; :meth:`run`
    processes a whole STFT ``(I, F, T)``. State persists across calls; :meth:`reset` clears it.
    """

    def __init__(
        self,
        n_channels: int,
        n_freqs: int,
        freqs_hz: np.ndarray | None = None,
        config: DPRTFConfig | None = None,
    ) -> None:
        if isinstance(n_channels, bool) or not isinstance(n_channels, int) or n_channels < 2:
            raise ValueError(
                f"DPRTFEstimator: n_channels must be an integer >= 2, got {n_channels!r}"
            )
        if isinstance(n_freqs, bool) or not isinstance(n_freqs, int) or n_freqs < 1:
            raise ValueError(
                f"DPRTFEstimator: n_freqs must be a positive integer, got {n_freqs!r}"
            )
        self.config = DPRTFConfig() if config is None else config
        self.n_channels = n_channels
        self.n_freqs = n_freqs
        q = self.config.ctf_length
        self.n_unknowns = n_channels * q
        #: the Cholesky solver runs the compiled per-bin kernel (Numba importable and not
        #: disabled by ``AVTRACK_NO_JIT``); False: the NumPy form, same results to ~1e-12
        self.compiled = _dprtf_kernel.available()
        self.forgetting = (
            forgetting_factor(n_channels, q, self.config.rho)
            if self.config.forgetting is None
            else float(self.config.forgetting)
        )
        n_pairs = n_channels * (n_channels - 1) // 2
        #: a bin gives features once it has had this many speech frames, enough for as many
        #: equations as unknowns (``P`` of thesis §5.2.2 with ``rho = 1``)
        self.min_frames = int(np.ceil((self.n_unknowns - 1) / n_pairs))
        #: memory (in frames' worth of equations) a bin needs to give features: that of
        #: ``min_frames`` consecutive speech frames from scratch (see the module docstring)
        self.min_memory = float(np.sum(self.forgetting ** np.arange(self.min_frames)))
        band = np.ones(n_freqs, dtype=bool)
        if self.config.freq_range_hz is not None:
            if freqs_hz is None:
                raise ValueError("DPRTFEstimator: freq_range_hz needs freqs_hz")
            f = np.asarray(freqs_hz, dtype=float)
            if f.shape != (n_freqs,):
                raise ValueError(
                    f"DPRTFEstimator: freqs_hz must have shape ({n_freqs},), got {f.shape}"
                )
            lo, hi = self.config.freq_range_hz
            band = (f >= lo) & (f <= hi)
        self.band = band
        # unknown ordering: coefficient-major, lags 1..Q-1 first and lag 0 last, so the first
        # CTF coefficients of the channels are the trailing I unknowns (see module docstring)
        self._lag_order = np.r_[np.arange(1, q), 0].astype(np.int64)
        self._pairs = [(i, j) for i in range(n_channels) for j in range(i + 1, n_channels)]
        self.reset()

    # -- state ---------------------------------------------------------------------------
    def reset(self) -> None:
        """Forget all history (CTF estimates, PSDs, noise statistics)."""
        i_, f_, q_ = self.n_channels, self.n_freqs, self.config.ctf_length
        n = self.n_unknowns
        self._xlag = np.zeros((f_, i_, q_), dtype=complex)  # x^i_{t-q,f} at [f, i, q]
        self._phi = np.zeros((f_, i_, q_), dtype=complex)  # eq. 5.10, [f, i, q]
        self._noise = (
            None
            if self.config.noise is None
            else NoiseTracker(f_, (i_, q_), self.config.noise, self.config.psd_smoothing)
        )
        self._started = np.zeros(f_, dtype=bool)  # bin has had a speech frame
        self._memory = np.zeros(f_)  # sum of lambda^age over the bin's speech frames in memory
        self._last = np.zeros(f_, dtype=np.int64)  # frame index of the bin's latest speech frame
        if self.config.solver == "cholesky":
            self._r = np.zeros((f_, n, n), dtype=complex)
        else:
            self._a = np.zeros((2, f_, n - 1), dtype=complex)
            self._p = np.zeros((2, f_, n - 1, n - 1), dtype=complex)
        self.frames_done = 0

    # -- one frame ---------------------------------------------------------------------------
    def step(self, frame: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Process one STFT frame.

        Parameters
        ----------
        frame : ndarray (n_channels, n_freqs), complex

        Returns
        -------
        values : ndarray (n_channels - 1, n_freqs), complex
            ``ĉ^i_{t,f}`` (0 where not valid).
        valid : ndarray (n_channels - 1, n_freqs), bool
        """
        values, valid, _ = self._step(frame)
        return values, valid

    def _step(self, frame: np.ndarray):
        i_, f_ = self.n_channels, self.n_freqs
        xt = frame.T  # (F, I)
        self._xlag[:, :, 1:] = self._xlag[:, :, :-1]
        self._xlag[:, :, 0] = xt
        beta = self.config.psd_smoothing
        # phi^i_{t,f} = beta phi^i_{t-1,f} + (1 - beta) x^i_{t,f} x^{1*}_{t,f}   (eq. 5.10)
        periodogram = self._xlag * xt[:, 0, None, None].conj()
        if self.frames_done == 0:  # start the average at the first periodogram, not at 0
            self._phi = periodogram
        else:
            self._phi = recursive_average(self._phi, periodogram, beta)
        ref_psd = self._phi[:, 0, 0].real
        if self._noise is None:
            speech, phi_hat = self.band.copy(), self._phi
        else:
            speech, _, phi_hat = self._noise.update(ref_psd, self._phi)
            speech &= self.band
        self.frames_done += 1
        values = np.zeros((i_ - 1, f_), dtype=complex)
        valid = np.zeros((i_ - 1, f_), dtype=bool)
        s = np.flatnonzero(speech)
        if s.size == 0:
            return values, valid, speech
        if self.config.solver == "cholesky" and self.compiled:
            if self._frame_compiled(phi_hat, s, values, valid):
                return values, valid, speech
        # v[f, q', k]: PSD vectors of the speech bins, lags in the unknowns' order
        v = np.ascontiguousarray(phi_hat[s][:, :, self._lag_order].transpose(0, 2, 1))
        age = self._age(s)
        if self.config.solver == "cholesky":
            z = self._update_cholesky(s, v, age)
        else:
            z = self._update_rls(s, v, age)
        c, ok = self._features(z)
        ok &= (self._memory[s] >= self.min_memory * (1.0 - 1e-9))[:, None]  # enough equations
        values[:, s] = np.where(ok, c, 0.0).T
        valid[:, s] = ok.T
        return values, valid, speech

    def _age(self, s: np.ndarray) -> np.ndarray:
        """Weight ``lambda^g`` of the memory of speech bins ``s`` (``g`` frames since their latest
        speech frame; ``g = 1`` without ``forget_over_noise``); updates the memory counts and
        restarts the bins whose memory has faded (see the module docstring)."""
        t = self.frames_done - 1  # index of the current frame
        lam = self.forgetting
        if self.config.forget_over_noise:
            gap = t - self._last[s]
            with np.errstate(under="ignore"):
                age = lam ** gap.astype(float)
        else:
            age = np.full(s.size, lam)
        if lam > 0 and self.config.forget_over_noise:  # lambda = 0 (Q = 1): R_t = U_t anyway
            faded = self._started[s] & (age < _FADED)
            self._started[s[faded]] = False
        new = ~self._started[s]
        self._memory[s] = np.where(new, 1.0, age * self._memory[s] + 1.0)
        self._last[s] = t
        return age

    def _frame_compiled(
        self, phi_hat: np.ndarray, s: np.ndarray, values: np.ndarray, valid: np.ndarray
    ) -> bool:
        """The speech bins' part of :meth:`_step` (memory weights, eq. 5.9 with the Cholesky
        solver, features) as one compiled loop (``avtrack.audio._dprtf_kernel``), writing
        ``values`` and ``valid``. Same arithmetic as the NumPy form; only the lower triangles
        of ``R`` are kept, and only the bins with enough memory are factorised. False (nothing
        done) if the kernel cannot be built here: the NumPy form from now on (warned once).
        """
        kern = _dprtf_kernel.kernel()
        if kern is None:
            self.compiled = False
            return False
        ok = kern(
            np.ascontiguousarray(phi_hat, dtype=complex),
            s.astype(np.int64, copy=False),
            self._lag_order,
            self._r,
            self._started,
            self._memory,
            self._last,
            self.frames_done - 1,
            float(self.forgetting),
            bool(self.config.forget_over_noise),
            float(self.min_memory),
            float(self.config.regularization),
            _LOADING,
            float(self.config.consistency_threshold),
            _FADED,
            bool(self.config.phase_only),
            values,
            valid,
        )
        if not ok:
            raise np.linalg.LinAlgError(
                "DPRTFEstimator: an RLS covariance is not positive definite (non-finite input?)"
            )
        return True

    def _update_cholesky(self, s: np.ndarray, v: np.ndarray, age: np.ndarray) -> np.ndarray:
        """R_t = lambda^g R_{t'} + sum_m x^{m*} x^{mT} (eq. 5.9); returns R^{-1}[A, refs]."""
        fs_, q_, i_ = v.shape
        n = self.n_unknowns
        whole = fs_ == self.n_freqs  # every bin is a speech bin: update R in place
        r = self._r if whole else self._r[s]  # (F_s, n, n)
        r5 = r.reshape(fs_, q_, i_, q_, i_)
        new = ~self._started[s]
        vc = v.conj()
        s_mat = np.matmul(vc, v.transpose(0, 2, 1))  # S[q, p] = sum_j conj(v^j_q) v^j_p
        trace_u = (i_ - 1) * np.einsum("fqq->f", s_mat).real  # trace of this frame's U
        if np.any(new):
            r[new] = 0.0
        r *= age[:, None, None]  # R_t = lambda R_{t-1} + U_t   (eq. 5.9); lambda^g after a gap
        # U[(q, k), (p, l)] = delta_kl S[q, p] - conj(v^l_q) v^k_p  (the pairs' sum, eq. 5.3)
        g = np.empty((fs_, q_, i_, q_, i_), dtype=complex)
        np.multiply(vc[:, :, None, None, :], v.transpose(0, 2, 1)[:, None, :, :, None], out=g)
        r5 -= g
        st = r5.strides
        blocks = np.lib.stride_tricks.as_strided(
            r5, shape=(fs_, q_, i_, q_), strides=(st[0], st[1], st[2] + st[4], st[3])
        )
        blocks += s_mat[:, :, None, :]
        # diagonal: R_0 = delta I at a bin's first speech frame (scale-free P_0 = I) and a
        # 1e-12 relative ridge that keeps R positive definite in round-off
        ridge = _LOADING * trace_u / n
        if np.any(new):
            ridge[new] += self.config.regularization * trace_u[new]
            self._started[s] = True
        diag = r.reshape(fs_, n * n)[:, :: n + 1]
        diag += np.maximum(ridge, np.finfo(float).tiny)[:, None]
        if not whole:
            self._r[s] = r
        chol = np.linalg.cholesky(r)
        l_aa = chol[:, n - i_ :, n - i_ :]
        schur = np.matmul(l_aa, l_aa.conj().transpose(0, 2, 1))  # = inverse of (R^{-1})_{AA}
        rhs = np.zeros((fs_, i_, 2), dtype=complex)
        rhs[:, 0, 0] = rhs[:, 1, 1] = 1.0
        return np.linalg.solve(schur, rhs)  # (F_s, I, 2): columns of R^{-1} for refs 1, 2

    def _update_rls(self, s: np.ndarray, v: np.ndarray, age: np.ndarray) -> np.ndarray:
        """Algorithm 2 per reference channel (1 and 2) on the speech bins."""
        fs_, q_, i_ = v.shape
        n = self.n_unknowns
        # full equation vectors x^{ij} (eq. 5.3, PSDs instead of STFT vectors): block of
        # channel i holds v^j, block of channel j holds -v^i; layout [f, m, q', k]
        x = np.zeros((fs_, len(self._pairs), q_, i_), dtype=complex)
        for m, (i, j) in enumerate(self._pairs):
            x[:, m, :, i] = v[:, :, j]
            x[:, m, :, j] = -v[:, :, i]
        x = x.reshape(fs_, len(self._pairs), n)
        new = ~self._started[s]
        s_mat_trace = np.einsum("fqk,fqk->f", v[new].conj(), v[new]).real
        delta = np.maximum(
            self.config.regularization * (i_ - 1) * s_mat_trace, np.finfo(float).tiny
        )
        out = np.zeros((fs_, i_, 2), dtype=complex)
        for ref in range(2):
            col = n - i_ + ref  # index of a^{ref}_0 (fixed to 1)
            keep = np.r_[0:col, col + 1 : n]
            a = self._a[ref, s]
            p = self._p[ref, s]
            p[~new] /= age[~new, None, None]  # P^0_t = lambda^{-1} P^M_{t-1} (lambda^-g)
            a[new] = 0.0
            p[new] = np.eye(n - 1) / delta[:, None, None]
            y = -x[:, :, col]  # the fixed coefficient's term moved to the right (eq. 5.5)
            a, p = rls_pair_updates(a, p, x[:, :, keep], y)
            p = 0.5 * (p + p.conj().transpose(0, 2, 1))  # keep P Hermitian (round-off)
            self._a[ref, s] = a
            self._p[ref, s] = p
            full = np.insert(a, col, 1.0, axis=1)  # (F_s, n) with a^{ref}_0 = 1
            out[:, :, ref] = full[:, n - i_ :]
        self._started[s] = True
        return out

    def _features(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        values, valid, _ = dprtf_features(
            z[:, 1:, 0] / z[:, :1, 0],  # c~^i = a^i_0 / a^1_0 (reference 1)
            z[:, 1:, 1] / z[:, :1, 1],  # c̄^i / c̄^1 (reference 2): the same DP-RTF
            self.config.consistency_threshold,
            self.config.phase_only,
        )
        return values, valid

    # -- batch ---------------------------------------------------------------------------
    def run(self, spec: np.ndarray) -> DPRTFFeatures:
        """Process the frames of an STFT ``(n_channels, n_freqs, n_frames)`` in order."""
        spec = np.asarray(spec)
        if spec.ndim != 3 or spec.shape[:2] != (self.n_channels, self.n_freqs):
            raise ValueError(
                f"DPRTFEstimator.run: spec must have shape ({self.n_channels}, {self.n_freqs}, "
                f"n_frames), got {spec.shape}"
            )
        t_ = spec.shape[2]
        values = np.zeros((self.n_channels - 1, self.n_freqs, t_), dtype=complex)
        valid = np.zeros(values.shape, dtype=bool)
        speech = np.zeros((self.n_freqs, t_), dtype=bool)
        for t in range(t_):
            values[:, :, t], valid[:, :, t], speech[:, t] = self._step(spec[:, :, t])
        return DPRTFFeatures(values, valid, speech)
