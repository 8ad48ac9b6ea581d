"""Planning: the league NLP built once per structure, and the solver that runs it safely."""
