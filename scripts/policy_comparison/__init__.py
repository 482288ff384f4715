"""What ``train_ppo.py`` and ``train_rllib.py`` share: the held-out comparison and the plot.

* :mod:`policy_comparison.evaluation`: a trained policy, random actions, the
  best constant action and the frontier policy on the same held-out episodes;
* :mod:`policy_comparison.curves`: the learning curve's plot, with those
  policies' figures as lines.
"""
