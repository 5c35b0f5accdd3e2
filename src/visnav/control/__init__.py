"""visnav.control"""
