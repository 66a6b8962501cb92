"""The version of stackik (one definition; ``stackik.__version__`` and ``stackik --version``
read it from here). Keep it equal to ``version`` in ``pyproject.toml``."""

__version__ = "0.1.0"
