"""Audio-visual tracking: audio features for the image plane (thesis §4.7.2), the GLLiM
audio-to-image mapping (eqs. 4.13–4.16), its calibration set, and diarization (eq. 4.34)."""
