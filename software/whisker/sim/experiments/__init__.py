"""The paper's experiments and our own, each a repeat of scenes: the grasp table, displacement against
time, classification data, open against closed loop, labelled state sequences, the tip-force check."""
