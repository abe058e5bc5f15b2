// Tests of the velodyne decoder land with it.
