"""Type stubs of the extension module ``vorl._vorl`` (re-exported by ``vorl``)."""

import os
from typing import Any, Dict, List, Literal, Mapping, Optional, Sequence, Tuple, Union, overload

import numpy as np
import numpy.typing as npt

PathLike = Union[str, "os.PathLike[str]"]
Frame = npt.NDArray[np.uint8]
"""A 2-D ``uint8`` array (height, width), 8-bit gray; ``(H, W, 1)`` is taken too. Any strides:
a row-major array without padding is read in place, others are copied once."""
Background = Union[PathLike, Frame, Sequence[Union[PathLike, Frame]], Literal["auto"], None]
ParamValue = Union[int, float, str, bool]
Part = Dict[str, Any]
"""One part: the keys of ``vorl detect --json``: ``class`` (``None`` for an unknown part),
``x``, ``y`` (area centroid, px), ``angle_deg`` (counter-clockwise on screen, 0-360), ``score``,
``best_class``, ``searches``, ``angle_dp_deg``, ``angle_paper_deg``, ``polygon_centroid``; when
verified ``verify_px``, ``verify_limit``, ``scale``; and when they apply ``flipped``,
``partial``, ``touching``, ``visible_fraction``, ``position``, ``holes``."""

class VorlError(ValueError):
    """An input vorl cannot use: a missing or unreadable file, an array of the wrong dtype or
    shape, an empty array, invalid parameters. The message is the ``vorl`` program's one-line
    message."""

class VorlWarning(UserWarning):
    """What a frame held that the engine could not take (the ``note:`` lines of
    ``vorl detect``: borders skipped, more parts than a frame reports, a frame that mostly
    differs from the background), a converted image file, and ``vorl teach``'s warnings."""

class Recognizer:
    """Recognises taught parts in 8-bit gray frames: which part, where, how far turned.

    Thread-safe: ``detect`` releases the GIL while the engine runs, so a capture thread keeps
    running; two recognisers detect in parallel, one recogniser's calls take turns.
    """

    def __init__(
        self,
        templates: Optional[PathLike] = None,
        config: Union[PathLike, Mapping[str, ParamValue], None] = None,
        background: Background = None,
        **params: ParamValue,
    ) -> None:
        """Builds a recognizer piece by piece.

        Args:
            templates: a template folder as ``vorl detect --templates`` takes it
                (``<class>.png`` silhouettes, or ``<class>/`` folders of several examples);
                ``None``: no templates yet (``add_template``), every part is unknown.
            config: a ``vorl.toml`` file, or a dict of its keys; ``None``: the defaults.
            background: the empty platform: an image file, an array, or a list of them (all
                learned); ``None`` or ``"auto"``: the platform is estimated from the frames.
            **params: single parameters on top of ``config`` (``threshold=30``,
                ``touching_parts=True``; the keys of :func:`config_defaults`).

        Raises:
            VorlError: a missing or unreadable folder or file, a template that is not one part,
                an unknown parameter or a value out of range.
        """

    @staticmethod
    def from_set(
        path: PathLike,
        config: Union[PathLike, Mapping[str, ParamValue], None] = None,
        **params: ParamValue,
    ) -> "Recognizer":
        """A recognizer from a fixture set folder, as ``vorl detect SET`` builds it:
        ``templates/``, ``vorl.toml`` when present, ``background.png`` and ``backgrounds/*.png``
        when present (else the platform is estimated from the frames). ``config`` and
        ``params`` go on top of the set's ``vorl.toml``.

        Raises:
            VorlError: as the ``vorl`` program for that set.
        """

    def detect(self, frame: Frame) -> List[Part]:
        """The parts in one frame, each a dict with the keys of ``vorl detect --json``, in
        the order the program lists them.

        Args:
            frame: a 2-D ``uint8`` array (height, width). A 3-channel image is refused:
                convert it with ``cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)`` first.

        Raises:
            VorlError: a wrong dtype or shape, an empty array, a frame of another size than
                the empty shot.
            TypeError: ``frame`` is not a NumPy array.
        """

    def add_template(self, name: str, silhouette: npt.NDArray[Union[np.uint8, np.bool_]]) -> None:
        """Teaches one more template: ``silhouette`` (part above 127, or ``True``; as
        :func:`teach` returns it) under class ``name``. A name already taught adds another
        example of that class (its tolerance is measured anew, as for a folder of examples).

        Raises:
            VorlError: the silhouette holds no part or several, or the library is full.
        """

    @property
    def classes(self) -> List[str]:
        """The class names taught, in order, each once."""

    @property
    def config(self) -> Dict[str, ParamValue]:
        """The parameters in use (the keys of :func:`config_defaults`)."""

    @property
    def auto_background(self) -> bool:
        """Whether the platform is estimated from the frames (no empty shot)."""

@overload
def teach(
    frame: Frame,
    at: Optional[Tuple[float, float]] = None,
    part: Optional[int] = None,
    background: Background = None,
    config: Union[PathLike, Mapping[str, ParamValue], None] = None,
    return_info: Literal[False] = False,
    **params: ParamValue,
) -> npt.NDArray[np.uint8]: ...
@overload
def teach(
    frame: Frame,
    at: Optional[Tuple[float, float]] = None,
    part: Optional[int] = None,
    background: Background = None,
    config: Union[PathLike, Mapping[str, ParamValue], None] = None,
    *,
    return_info: Literal[True],
    **params: ParamValue,
) -> Tuple[npt.NDArray[np.uint8], Dict[str, Any]]: ...
def teach(
    frame: Frame,
    at: Optional[Tuple[float, float]] = None,
    part: Optional[int] = None,
    background: Background = None,
    config: Union[PathLike, Mapping[str, ParamValue], None] = None,
    return_info: bool = False,
    **params: ParamValue,
) -> Union[npt.NDArray[np.uint8], Tuple[npt.NDArray[np.uint8], Dict[str, Any]]]:
    """The silhouette ``vorl teach`` would save: the part at pixel ``at=(x, y)`` (inside it,
    within 3 px of its outline or of its centre), or part number ``part`` (1-based, as
    ``vorl teach --list`` numbers them), or the largest part; cut at half its contrast along
    its outline, part 255 and rest 0 with a 10 px margin. ``background`` is the empty platform
    (``None``: estimated from the frame). With ``return_info=True`` also a dict:
    ``polarity`` (``"either"``, ``"darker"`` or ``"brighter"``: keep a one-sided one as the
    recognizer's ``polarity`` parameter, as ``vorl teach`` writes it into ``vorl.toml``),
    ``polarity_note``, ``area``, ``auto_background``, ``warnings``.

    Raises:
        VorlError: no part in the frame, no part at ``at``, a ``part`` number out of range.
    """

def config_defaults() -> Dict[str, ParamValue]:
    """Every parameter with its default (what ``vorl config --defaults`` writes)."""

def imread(path: PathLike) -> npt.NDArray[np.uint8]:
    """An image file (PNG, GIF, BMP) as a 2-D ``uint8`` array, converted to 8-bit gray as the
    ``vorl`` program reads it (a :class:`VorlWarning` says when it was converted).

    Raises:
        VorlError: a missing, unreadable or oversized file.
    """
