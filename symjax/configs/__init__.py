"""Named presets (``configs/*.toml``) and the loader that turns them into typed configs.

``symjax.configs.load("paper")`` returns a :class:`Preset` whose fields are the frozen config
dataclasses of every stage; a user's own TOML file in the same layout loads the same way.
"""

from symjax.configs.preset import SECTIONS, Preset, load, preset_names

__all__ = ["SECTIONS", "Preset", "load", "preset_names"]
