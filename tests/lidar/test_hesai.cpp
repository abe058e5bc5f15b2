// Tests of the hesai decoder land with it.
