"""Networked shows over Eclipse Zenoh: time sync, show clocks, heartbeats, relays."""
