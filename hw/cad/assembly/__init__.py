"""The assembled sensor: every part in place, the assembly sequence swept along its paths, the swing of every whisker."""
