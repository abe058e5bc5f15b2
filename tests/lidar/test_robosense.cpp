// Tests of the robosense decoder land with it.
