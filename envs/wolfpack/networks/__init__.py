"""The networks of a saved model, which playing a model needs as much as training it: the flat
observation's MLP actor and critic (:mod:`wolfpack.networks.mlp`) and the set networks over
entity observations (:mod:`wolfpack.networks.sets`). This module imports no torch, so that
checking a recipe does not need it."""

#: The set network's poolings (the recipe's ``pool``).
POOLS = ("attention", "mean_max")
