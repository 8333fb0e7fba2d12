"""The embedded dataset: procedurally generated, text-labelled motion on the HumanML3D ``t2m`` skeleton.

>>> from motionlab.data.embedded import ensure_embedded   # doctest: +SKIP
>>> root = ensure_embedded("smoke")                       # generated once, then read from the cache
"""

from .generator import FAMILIES, MAX_FRAMES, MIN_FRAMES, VERSION, EmbeddedClip, generate_clip
from .writer import embedded_path, ensure_embedded, write_embedded_dataset

__all__ = [
    "FAMILIES",
    "MAX_FRAMES",
    "MIN_FRAMES",
    "VERSION",
    "EmbeddedClip",
    "embedded_path",
    "ensure_embedded",
    "generate_clip",
    "write_embedded_dataset",
]
