"""The attitude-tracking task (``attitude``) and its two environments: the batched TorchRL one
(``torchrl_env``) and the gymnasium one (``gym_env``); ``metrics`` scores flights."""
