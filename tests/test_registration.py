"""Adding an algorithm is its folder and one registry line: a toy algorithm in a package of its own is picked up by
the zoo bridge (sampler, converter, hyperparameters), the harness and the SB3 contract."""






