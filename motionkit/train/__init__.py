"""The slim AMP + PPO trainer on MuJoCo MJX."""
