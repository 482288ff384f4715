"""PettingZoo environments built on the tomosim simulation core."""
