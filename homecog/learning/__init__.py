"""The learning stage: Sarsa over the environment, and the Q table it makes."""
