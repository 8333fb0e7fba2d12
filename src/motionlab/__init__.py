"""motionlab: the library behind an executable book on DisCoRD and M2D2M (text-to-motion)."""

__version__ = "0.1.0"
