"""Tests of the transports (python/src/drempower/transports/): each link up to the OS boundary."""
