"""The site's working state, written through on every change and restored at start.

One :class:`~.store.StateStore` per robot identity (its own folder); nodes and the simulator
put their sections into it. It imports nothing of ours, so every floor above may use it.
"""

from .binding import StateBinding
from .files import StateFolderError
from .journal import JournalError
from .loading import Restored
from .location import default_root, identity_folder
from .store import StateStore, StateWriteError

__all__ = ["JournalError", "Restored", "StateBinding", "StateFolderError", "StateStore",
           "StateWriteError", "default_root", "identity_folder"]
