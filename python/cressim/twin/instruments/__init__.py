"""An arm's instrument as plug-ins (cressim.twin.instruments.instrument says what one has): each
tool function is one class, built where the arm's tool and world have what it needs, hooked
around the tick's one engine frame. Add a tool function by writing its class and listing it in
PLUGINS (the order is the order of the hooks in a tick)."""
from .cautery import Cautery
from .contact import TOOL_LINKS, ContactWrench
from .instrument import Instrument
from .jaws import Jaws
from .needle import Needle
from .suction import SUCTION_TIP, Suction

PLUGINS = (Jaws, Needle, Suction, Cautery, ContactWrench)


def build_instruments(arms) -> dict:
    """name -> instrument, for the plug-ins that `arms` (a TwinArms) can carry."""
    built = {}
    for plugin in PLUGINS:
        instrument = plugin.build(arms)
        if instrument is not None:
            built[plugin.name] = instrument
    return built


def command_plugin(kind: str):
    """The plug-in class that takes a client command of this kind (None: no instrument does)."""
    return next((p for p in PLUGINS if kind in p.commands), None)


__all__ = ["Cautery", "ContactWrench", "Instrument", "Jaws", "Needle", "PLUGINS", "SUCTION_TIP", "Suction",
           "TOOL_LINKS", "build_instruments", "command_plugin"]
