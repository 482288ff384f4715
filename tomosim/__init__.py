"""tomosim: simulation core (worlds, robots, lidar, mapping, exploration, recording, CLI)."""
