"""vorl — which part, where, how far turned.

The contour-matching recognizer of the ``vorl`` program, for NumPy arrays and OpenCV frames::

    import vorl
    rec = vorl.Recognizer.from_set("examples/plant")   # templates/, vorl.toml, background.png
    for part in rec.detect(frame):                      # frame: 2-D uint8 array (H, W)
        print(part["class"], part["x"], part["y"], part["angle_deg"])

Each part is a dict with the keys of ``vorl detect --json``. Errors are :class:`VorlError`
(a :class:`ValueError`) with the program's one-line messages; what a frame held that the
engine could not take is a :class:`VorlWarning`.
"""

from ._vorl import (
    Recognizer,
    VorlError,
    VorlWarning,
    config_defaults,
    imread,
    teach,
)

__all__ = [
    "Recognizer",
    "VorlError",
    "VorlWarning",
    "config_defaults",
    "imread",
    "teach",
]
__version__ = "0.1.0"
