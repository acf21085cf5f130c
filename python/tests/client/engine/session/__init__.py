"""Client behaviour on scripted time: a BusSession driven frame by frame, no sleeps."""
