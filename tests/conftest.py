"""Settings for the whole test session."""

import os

# A local Ray binds to the machine's network address by default; tests keep all their traffic
# on loopback (Ray reads this when it is first imported, and its processes inherit it).
os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")
