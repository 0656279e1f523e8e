"""xgo-show: choreograph, compile and run shows for XGO robot dogs and the LewanSoul xArm."""

__version__ = "0.1.0"
