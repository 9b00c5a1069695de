"""Named registries: the controllers, agents, predictors and pedestrian behaviours by name.

    AGENTS = Registry("agent", base=Agent)

    @AGENTS.register("point")
    class Point(Agent): ...

    AGENTS.get("point")     # Point; an unknown name is one ValueError listing the known ones
    AGENTS.names()          # sorted, whatever the order of registration

`builtins` names modules that register entries when imported: they are imported on the first
lookup, so that importing the registry alone loads none of them.
"""

import importlib


class Registry:
    """Entries of one kind by name.

    Args:
      kind: what an entry is, for messages ("controller", "agent", ...).
      base: the class every entry must subclass (None: anything).
      builtins: modules imported on the first lookup (they register the built-in entries).
      hint: what else a lookup accepts, appended to the unknown-name message.
    """

    def __init__(self, kind, base=None, builtins=(), hint=None):
        self.kind, self.base, self.hint = kind, base, hint
        self._builtins = tuple(builtins)
        self._entries = {}

    def register(self, name):
        """Decorator adding `obj` under `name` (a class also gets `obj.name = name`).

        A name already taken by another entry is a ValueError, unless the new entry is a class
        of the same module and qualified name (the same definition run again)."""

        def add(obj):
            if self.base is not None and not (isinstance(obj, type) and issubclass(obj, self.base)):
                raise TypeError(
                    f"{self.kind} {name!r} must be a subclass of {self.base.__name__}; got {obj!r}"
                )
            old = self._entries.get(name)
            if old is not None and old is not obj and not _redefined(old, obj):
                raise ValueError(
                    f"{self.kind} {name!r} is registered already ({old!r}); unregister it first "
                    "or choose another name"
                )
            self._entries[name] = obj
            if isinstance(obj, type):
                obj.name = name
            return obj

        return add

    def unregister(self, name):
        """Removes entry `name` if there is one."""
        self._entries.pop(name, None)

    def names(self) -> list[str]:
        """The registered names, sorted."""
        self._load()
        return sorted(self._entries)

    def get(self, name):
        """The entry of `name`; an unknown name is a ValueError naming it and the known ones."""
        self._load()
        if name not in self._entries:
            hint = f", {self.hint}" if self.hint else ""
            raise ValueError(
                f"unknown {self.kind} {name!r}; valid names: {', '.join(self.names())}{hint}"
            )
        return self._entries[name]

    def __contains__(self, name):
        self._load()
        return name in self._entries

    def _load(self):
        while self._builtins:
            module, *rest = self._builtins
            importlib.import_module(module)
            self._builtins = tuple(rest)


def _redefined(old, new):
    """Whether classes `old` and `new` have one module and qualified name."""
    if not (isinstance(old, type) and isinstance(new, type)):
        return False
    return (old.__module__, old.__qualname__) == (new.__module__, new.__qualname__)
