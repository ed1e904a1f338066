"""Models built from MJCF as the tests build them: gymnasium's files, or a test's own XML text.

Why: a dozen test files built gymnasium's hopper with the same six lines (find the file, quiet the
warning about its self-collision pairs, compile), and as many wrote their own XML to a file and
compiled it the same way; each now says only what differs: its model, name, functions and
options."""
import warnings
from pathlib import Path

import pytest


def gym_file(name):
    """The path of gymnasium's envs/mujoco/assets/<name> (the test is skipped without gymnasium)."""
    gymnasium = pytest.importorskip("gymnasium")
    return Path(gymnasium.__file__).parent / "envs" / "mujoco" / "assets" / name


def gym_model(file, name, cache_dir, functions, **options):
    """eomc.compile of gymnasium's ``file`` (its self-collision pairs left out, as MjcfModel's
    default says by a warning, silenced here) as ``name`` into ``cache_dir``; ``options``: compile's."""
    import eomc
    from eomc.compiler.mjcf.model import MjcfModel
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return eomc.compile(MjcfModel(gym_file(file)), name, functions=functions, cache_dir=cache_dir,
                            progress=False, **options)


def text_model(text, name, directory, functions, mjcf=None, **options):
    """eomc.compile of the MJCF ``text`` (written to ``directory``/<name>.xml; MjcfModel's keyword
    arguments ``mjcf``, its warnings silenced) as ``name``, cached in ``directory``/cache."""
    import eomc
    from eomc.compiler.mjcf.model import MjcfModel
    path = Path(directory) / f"{name}.xml"
    path.write_text(text)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return eomc.compile(MjcfModel(path, **(mjcf or {})), name, functions=functions,
                            cache_dir=Path(directory) / "cache", progress=False, **options)
