"""How an inserted object looks: its appearance (paint, clothes), its number plates, and the measures the look is judged by."""
