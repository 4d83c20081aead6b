"""Training of recurrent Soft Actor-Critic attitude controllers (see scripts/train_torchrl.py)."""
