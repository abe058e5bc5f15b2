// Tests of the ouster decoder land with it.
