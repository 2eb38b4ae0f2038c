"""The simulator's effect graph (which physics a scene needs, and why) and the effects it can build:
airflow drag, compliant Hertz contact and its mapping onto MuJoCo."""
